"""rerunio.Recorder, the base of both commands' recorders: a failed write is noticed within CHECK_EVERY steps
and reported once, naming the target; the recording is closed exactly once, also after a failed write (a stream
left open made objrec-detect and objrec-patrol hang at exit on a full disk)."""

from __future__ import annotations

import pytest

pytest.importorskip("rerun")

from rerunio import CHECK_EVERY, Recorder
from strictio import OutputError


class Stream:
    """A recording stream whose writes start failing after ``good_flushes`` flushes (a disk filling up)."""

    def __init__(self, good_flushes: int) -> None:
        self.good_flushes = good_flushes
        self.flushes = 0
        self.disconnects = 0
        self.times: list[tuple[str, dict[str, float]]] = []

    def flush(self) -> None:
        self.flushes += 1
        if self.flushes > self.good_flushes:
            raise RuntimeError("failed to write: No space left on device")

    def disconnect(self) -> None:
        self.disconnects += 1

    def set_time(self, timeline: str, **value: float) -> None:
        self.times.append((timeline, value))


def test_a_failed_write_is_noticed_at_the_first_check_after_it():
    stream = Stream(good_flushes=1)
    recorder = Recorder(stream)
    recorder.target = "out/run.rrd"
    for _ in range(2 * CHECK_EVERY - 1):
        recorder.step_logged()
    assert stream.flushes == 1  # the check after step 50 passed; none since
    with pytest.raises(OutputError, match=r"^out/run\.rrd: cannot be written: failed to write: No space left"):
        recorder.step_logged()  # step 100
    assert stream.disconnects == 1  # shut down at once: a stream left open can hang the process at exit
    recorder.close()  # already failed: nothing more to flush or disconnect
    assert (stream.flushes, stream.disconnects) == (2, 1)


def test_close_flushes_and_disconnects_once():
    stream = Stream(good_flushes=10)
    with Recorder(stream) as recorder:
        recorder.set_time("frame", sequence=7)
    recorder.close()
    assert (stream.flushes, stream.disconnects) == (1, 1)
    assert stream.times == [("frame", {"sequence": 7})]


def test_a_failure_at_close_names_the_target():
    recorder = Recorder(Stream(good_flushes=0))
    with pytest.raises(OutputError, match=r"^the Rerun recording: cannot be written: failed to write"):
        recorder.close()
