"""What every Rerun recorder of the project does besides logging its own entities: timelines, noticing a
failed write while recording, and closing the recording exactly once.

rerun reports a failed file write (a full disk) only when the recording is flushed, and a lost viewer only at
the next flush or disconnect. So a recorder flushes every :data:`CHECK_EVERY` logged steps (a frame, a
sample of the simulation) and turns what rerun raises into one ``strictio.OutputError`` naming the target as
the user gave it: the command then ends with one line soon after, rather than after every frame was logged
into nowhere. A ``.rrd`` file (:class:`rerunio.rrd_file.RrdFile`) is then removed, and renamed to its own name
only when the recording closed whole. objrec-detect's
:class:`objrec_apps.rerun_log.RerunRecorder` and objrec-patrol's
:class:`navigation.rerun_log.PatrolRecorder` are both made on this base.
"""

from __future__ import annotations

import contextlib
from typing import Any, Self

from strictio import OutputError

#: Logged steps between two checks that the recording is still being written.
CHECK_EVERY = 50


def _reason(exc: Exception) -> str:
    """What rerun says of a failed write, one line; its writer thread's end is the full disk it does not name."""
    text = " ".join(str(exc).split())
    if "shut down prematurely" in text:
        return f"the disk is full or a file size limit was reached ({text})"
    return text


class Recorder:
    """A Rerun ``RecordingStream`` being written, closed once; subclasses log their entities through it.

    ``target`` is where the recording goes as the user named it, for error messages. A subclass calls
    :meth:`step_logged` after each frame or sample, and does its own last logging in :meth:`_before_close`.
    """

    #: Where the recording goes, as the user named it (for error messages).
    target = "the Rerun recording"
    #: Logged steps between two flushes that check the writing.
    check_every = CHECK_EVERY

    def __init__(self, recording: Any) -> None:
        import rerun as rr

        from . import file_of  # the package imports this module first

        self._rr = rr
        self.recording = recording
        self.steps = 0
        self._closed = False
        self._file = file_of(recording)

    def set_time(self, timeline: str, **value: float | int) -> None:
        """Put what is logged next at ``value`` on ``timeline`` (``sequence=``, ``duration=`` or
        ``timestamp=``, as ``rr.RecordingStream.set_time`` takes them)."""
        self.recording.set_time(timeline, **value)

    def step_logged(self) -> None:
        """Count one frame or sample logged; every :attr:`check_every` of them, check the writing."""
        self.steps += 1
        if self.steps % self.check_every == 0:
            self.check_writing()

    def check_writing(self) -> None:
        """Flush now: OutputError (and nothing more to close, a file removed) if the recording can no longer be
        written."""
        try:
            self.recording.flush()
        except Exception as exc:  # rerun reports a full disk or a lost viewer as a RuntimeError
            self._shut()
            raise OutputError(self.target, f"cannot be written: {_reason(exc)}{self._nothing_kept}") from None

    @property
    def _nothing_kept(self) -> str:
        return "; nothing was kept" if self._file is not None else ""

    def _shut(self) -> None:
        """After a failure: nothing more is written or closed; a file is removed, the stream shut down now (one
        left open is flushed again at interpreter exit, which can then wait for ever on rerun's writer)."""
        from . import forget_file

        self._closed = True
        with contextlib.suppress(Exception):
            self.recording.disconnect()
        if self._file is not None:
            self._file.abandon()
            forget_file(self.recording)

    def _before_close(self) -> None:
        """A subclass's last logging and unhooking, done once, before the recording is flushed and closed."""

    def close(self) -> None:
        """Flush everything logged and close the file (its footer written, then renamed to its own name) or the
        viewer connection; OutputError if that fails (a file is then removed). Closing again, or after a failed
        check, does nothing."""
        if self._closed:
            return
        self._before_close()
        try:
            self.recording.flush()
            self.recording.disconnect()
        except Exception as exc:  # rerun reports a full disk or a lost viewer as a RuntimeError
            self._shut()
            raise OutputError(self.target, f"cannot be written: {_reason(exc)}{self._nothing_kept}") from None
        self._closed = True
        if self._file is not None:
            from . import forget_file

            forget_file(self.recording)
            self._file.finish()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
