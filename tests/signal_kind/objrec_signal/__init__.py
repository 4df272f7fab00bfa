"""objrec_signal: a third data kind, 1-D signals, plugged into objrec with no change to objrec itself.

A frame is a 1-D float NumPy array (samples). ``MovingAverageFilter`` smooths it, ``PeakDetector`` reports
the peaks above a threshold as ``SignalPeak`` objects (name, sample position, height), and ``WaveSource``
(``wave:seed=N,frames=N,...`` or a ``.sig`` file) supplies frames. Only NumPy and objrec_core are imported:
pictures are drawn with NumPy, so the kind needs no OpenCV.
"""

from .kind import SignalKind, SignalPeak, SignalPeakArray, plot_signal
from .modules import MovingAverageFilter, PeakDetector
from .sources import WaveSource, read_signal_file

__all__ = [
    "MovingAverageFilter",
    "PeakDetector",
    "SignalKind",
    "SignalPeak",
    "SignalPeakArray",
    "WaveSource",
    "plot_signal",
    "read_signal_file",
]
