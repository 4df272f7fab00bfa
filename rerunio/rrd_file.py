"""A ``.rrd`` file being written: under a temporary name, renamed when the recording closes whole, removed when
writing it failed, so that a full disk neither hangs the command nor leaves a file a viewer cannot read.

rerun-sdk 0.41 writes the file on a thread of its own. When that thread cannot write its first bytes (a disk
already full), ``RecordingStream.save`` can wait for it for ever inside native code, where no signal reaches
Python (``--rerun`` onto a full disk hung past 60 s and left its file). So before rerun is given the
file, :class:`RrdFile` writes :data:`PROBE_BYTES` into it itself: a disk that cannot take them is one
``strictio.OutputError`` at once, and rerun's writer is never started. A disk that fills up later is
reported by rerun at the next flush (``rerunio.Recorder`` flushes every few steps).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Any

from strictio import OutputError
from strictio.atomic import check_replaceable, remove_stale_temporaries, temporary_path

#: What the file must be able to take before rerun's writer starts: more than a recording's first bytes
#: (its header and the blueprint, a few KiB), far less than any useful recording.
PROBE_BYTES = 256 * 1024


class RrdFile:
    """The ``.rrd`` file of one recording stream; ``shown`` is the path as the user gave it."""

    def __init__(self, stream: Any, path: Path, shown: str, blueprint: Any = None) -> None:
        self.shown = shown
        self.target = Path(os.path.realpath(path))
        check_replaceable(shown, self.target)  # a FIFO would block for ever, a read-only file stays as it is
        remove_stale_temporaries(self.target.parent)
        self.temporary = temporary_path(self.target, ".rrd")
        self._probe()
        self._open = True
        try:
            stream.save(self.temporary, default_blueprint=blueprint)
        except BaseException:
            self.abandon()
            raise

    def _probe(self) -> None:
        """Create the temporary and see that it takes :data:`PROBE_BYTES`, then empty it for rerun."""
        try:
            fd = os.open(self.temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o644)
        except OSError as exc:
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}") from None
        try:
            view = memoryview(bytes(PROBE_BYTES))
            while view:
                view = view[os.write(fd, view):]
            os.ftruncate(fd, 0)
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.unlink(self.temporary)
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}; nothing was kept") from None
        finally:
            os.close(fd)

    def finish(self) -> None:
        """After rerun closed the file whole: rename it to its own name (OutputError, and no file, if that
        fails)."""
        if not self._open:
            return
        self._open = False
        try:
            os.replace(self.temporary, self.target)
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.unlink(self.temporary)
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}; nothing was kept") from None

    def abandon(self) -> None:
        """Remove the file: writing it failed, and what it holds is not whole."""
        self._open = False
        with contextlib.suppress(OSError):
            os.unlink(self.temporary)
