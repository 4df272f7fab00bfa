"""foxgloveio: the Foxglove live view every command can start (``--foxglove [HOST:]PORT``), see
:mod:`foxgloveio.server`.

Beside :mod:`rerunio` and for the same reason: objrec-detect, objrec-inspect and the navigation stack's
objrec-patrol all serve one, and none of them may depend on another's package. It imports nothing of the
project but the floor (strictio), and foxglove-sdk only when a server starts.
"""
