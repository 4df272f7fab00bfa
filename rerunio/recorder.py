"""What every Rerun recorder of the project does besides logging its own entities: timelines, noticing a
failed write while recording, and closing the recording exactly once.

rerun reports a failed file write (a full disk) only when the recording is flushed, and a lost viewer only at
the next flush or disconnect. So a recorder flushes every :data:`CHECK_EVERY` logged steps (a frame, a
sample of the simulation) and turns what rerun raises into one ``strictio.OutputError`` naming the target as
the user gave it: the command then ends with one line soon after, rather than after every frame was logged
into nowhere. objrec-detect's :class:`objrec_apps.rerun_log.RerunRecorder` and objrec-patrol's
:class:`navigation.rerun_log.PatrolRecorder` are both made on this base.
"""

from __future__ import annotations

import contextlib
from typing import Any, Self

from strictio import OutputError

#: Logged steps between two checks that the recording is still being written.
CHECK_EVERY = 50


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

        self._rr = rr
        self.recording = recording
        self.steps = 0
        self._closed = False

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
        """Flush now: OutputError (and nothing more to close) if the recording can no longer be written."""
        try:
            self.recording.flush()
        except Exception as exc:  # rerun reports a full disk or a lost viewer as a RuntimeError
            self._closed = True
            # shut the stream down now: one left open is flushed again at interpreter exit, which can then wait
            # forever on rerun's writer thread
            with contextlib.suppress(Exception):
                self.recording.disconnect()
            raise OutputError(self.target, f"cannot be written: {exc}") from None

    def _before_close(self) -> None:
        """A subclass's last logging and unhooking, done once, before the recording is flushed and closed."""

    def close(self) -> None:
        """Flush everything logged and close the file (its footer written) or the viewer connection;
        OutputError if that fails. Closing again, or after a failed check, does nothing."""
        if self._closed:
            return
        self._closed = True
        self._before_close()
        try:
            self.recording.flush()
            self.recording.disconnect()
        except Exception as exc:  # rerun reports a full disk or a lost viewer as a RuntimeError
            raise OutputError(self.target, f"cannot be written: {exc}") from None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
