"""A visit's camera frames on disk: a patrol that takes 2,000 frames at one pose keeps none of them in memory.

The tasks of a visit share its frames (a ``detect`` after a ``look_around`` runs on every heading's frame), so
they must be kept until the visit ends; a 640x480 RGB-D frame is some 2 MB, and 2,000 look_around headings or
500 photo tasks at one pose passed 2.5 GB when they were kept in memory. Each frame is written to
a private temporary folder (mode 0700) as it is taken and read back, one at a time, by whoever asks for it; the
folder is removed when the visit ends, or at the latest when the process exits.
"""

from __future__ import annotations

import logging
import os
import pickle
import tempfile
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)


class FrameStore:
    """One visit's folder of frames; made at the first frame, removed by :meth:`close`."""

    def __init__(self) -> None:
        self._folder: tempfile.TemporaryDirectory[str] | None = None
        self._count = 0
        self._failed = False

    def put(self, frame: Any) -> Path | None:
        """Write ``frame`` and return its file, or None when it cannot be written (a full temp folder: the
        frame then stays in memory, with one warning per visit)."""
        if self._failed:
            return None
        try:
            if self._folder is None:
                self._folder = tempfile.TemporaryDirectory(prefix="objrec-visit-")
            self._count += 1
            path = Path(self._folder.name) / f"{self._count:06d}.frame"
            with open(path, "xb") as stream:
                pickle.dump(frame, stream, protocol=pickle.HIGHEST_PROTOCOL)
            return path
        except (OSError, pickle.PicklingError, TypeError, AttributeError) as exc:
            self._failed = True
            log.warning("the visit's camera frames are kept in memory: cannot write them to the temp folder (%s)",
                        getattr(exc, "strerror", None) or exc)
            return None

    def close(self) -> None:
        """Remove the folder and every frame in it."""
        if self._folder is not None:
            self._folder.cleanup()
            self._folder = None


def load(path: Path) -> Any:
    """A frame written by :meth:`FrameStore.put` (a file of this process's own private folder)."""
    with open(path, "rb") as stream:
        if os.fstat(stream.fileno()).st_uid != os.getuid():  # never a file someone else put there
            raise RuntimeError(f"{path} is not this process's frame")
        return pickle.load(stream)  # written by this process, in a folder only it can enter
