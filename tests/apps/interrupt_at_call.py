"""Run a command (objrec-detect, -eval, -tune or -batch) and send it SIGINT at the Nth Python function call of its
start-up: from the moment the launcher's handler is in place until the run loop takes the signals over. With
N = -1 nothing is sent and the number of calls in that stretch is written to stderr (``CALLS n``), so that a test
can spread N over all of it.

Usage: python interrupt_at_call.py N LAUNCHER arguments...   (LAUNCHER: detect, evaluate, tune or batch)

A signal sent from inside a profile hook is handled at the next call, so every part of the start-up (imports,
a plug-in's class creation, entry-point scanning, opening the source) is hit, not just where a timer lands.
"""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType
from typing import Any

TARGET = int(sys.argv.pop(1)) if __name__ == "__main__" else -2  # -2: a worker process objrec-batch spawned
LAUNCHER = sys.argv.pop(1) if __name__ == "__main__" else ""
_install = signal.signal
_state = {"calls": 0, "counting": False, "sent": False}


def _profile(_frame: FrameType, event: str, _arg: Any) -> None:
    if event != "call" or not _state["counting"]:
        return
    _state["calls"] += 1
    if _state["calls"] == TARGET and not _state["sent"]:
        _state["sent"] = True
        os.kill(os.getpid(), signal.SIGINT)


def _watching(sig: int, handler: Any) -> Any:
    """signal.signal, noting where the stretch begins (the launcher's handler) and ends (the run loop's)."""
    previous = _install(sig, handler)
    if sig in (signal.SIGINT, signal.SIGTERM):
        # StopSignals (the run loop has the signals now), or objrec-batch taking SIGTERM as Ctrl-C for its run
        if getattr(handler, "__name__", "") in ("_handle", "raise_interrupt"):
            if _state["counting"] and TARGET < 0:
                sys.stderr.write(f"CALLS {_state['calls']}\n")
            _state["counting"] = False
        elif not _state["sent"] and _state["calls"] == 0 and callable(handler):
            _state["counting"] = True
    return previous


if __name__ == "__main__":  # not in the worker processes objrec-batch spawns, which import this file again
    signal.signal = _watching
    sys.setprofile(_profile)

    from objrec_apps import launch  # the launcher's handler must be watched from its start

    sys.exit(getattr(launch, LAUNCHER)())
