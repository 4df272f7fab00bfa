"""The contract every output of a detection run keeps: opened before the run, sinks added to the director,
closed once with how the run ended.

objrec-detect has five outputs at once (the detections as JSON Lines or typed messages, pictures, a Rerun
recording, the reasons) and objrec-batch one per source. What they share is how they end: each is closed
whatever happened, and what it keeps depends on the run's ending. A run that completed or was interrupted
(Ctrl-C, SIGTERM, a stop request) keeps everything written so far; a failed run keeps it too unless the
failure left nothing usable (``keep_partial`` false), in which case an all-or-nothing output (a bag) is left
out entirely. A failure to close is reported once, as the run's first error, and is exit code 2.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from strictio import OutputError

if TYPE_CHECKING:  # pragma: no cover
    from objrec_core import DetectionDirector


class Ending(Enum):
    """How a run ended."""

    COMPLETED = "completed"
    INTERRUPTED = "interrupted"  # Ctrl-C, SIGTERM, a stop request: what was done is kept
    FAILED = "failed"


#: The exit code of an output that cannot be written (as every user mistake).
OUTPUT_FAILED = 2


@dataclass(frozen=True)
class RunEnd:
    """How the run ended, as the outputs need to know it when they close.

    ``status`` is the exit code so far (non-zero: the failure was reported already); ``keep_partial`` false
    means the run wrote nothing usable, so an output that is all or nothing drops what it holds.
    """

    state: Ending = Ending.COMPLETED
    status: int = 0
    keep_partial: bool = True


class Output(ABC):
    """One place a run's results go: opened by its constructor, fed by the sinks it attaches, closed once."""

    #: The command-line option that asks for it (named in messages).
    option: ClassVar[str] = ""
    #: Errors of its own that already name its file and say why (reported as they are).
    named_errors: ClassVar[tuple[type[Exception], ...]] = (OutputError,)
    #: Whether it writes on stderr (then no progress bar is drawn amid its lines).
    uses_stderr: bool = False

    def __init__(self, path: str | None) -> None:
        self.path = path

    @abstractmethod
    def attach(self, director: DetectionDirector) -> None:
        """Add this output's sinks to the ``DetectionDirector`` (and ask it for stages if needed)."""

    @abstractmethod
    def close(self, end: RunEnd) -> None:
        """Finish (or, where the run left nothing usable, drop) what was written; a failure raises."""

    def summary(self) -> str | None:
        """The line saying what a completed run wrote here, or None."""
        return None

    def holds(self, path: str) -> bool:
        """Whether ``path`` (named by a failed write) is this output's file, or lies in its folder."""
        if not self.path:
            return False
        failed, mine = Path(path).resolve(), Path(self.path).resolve()
        return failed == mine or failed.is_relative_to(mine)


def close_outputs(outputs: Sequence[Output], end: RunEnd, report: Callable[[object], None]) -> int:
    """Close every output, the last opened first, each whatever the others did; the exit code afterwards.

    A failure to close (the last buffered bytes, a video's index, a bag's summary) is reported unless the run
    already failed and said so, and makes the exit code 2.
    """
    status = end.status
    for output in reversed(outputs):
        failure: object
        try:
            output.close(end)
        except output.named_errors as exc:
            failure = exc
        except OSError as exc:
            failure = f"writing {output.path}: {exc.strerror or exc}"
        else:
            continue
        if not status:
            report(failure)
        status = OUTPUT_FAILED
    return status
