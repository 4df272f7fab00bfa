"""``objrec-detect --explain[=PATH]``: why detectors found nothing, on stderr or in a side file.

The reasons come from an outcome sink of the DetectionDirector (:class:`objrec_core.explain.ReasonSink`);
this module only chooses where they go. The side file is streamed like a JSON Lines ``--output`` (opened by
the same helper, flushed per line so it can be followed live); a side file that cannot be written, at its
first line or later, is an output that cannot be written: one error line and exit code 2, as for every output,
with the lines written before it kept.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import IO

from objrec_core.explain import ReasonSink
from strictio import OutputError

from .cli import open_text_output

OPTION = "--explain"
#: The value of a bare ``--explain``: the reasons go to stderr.
STDERR = "-"
HELP = (
    "per frame and detector, write why a detector found nothing: as text on stderr (--explain), or as JSON "
    "lines into a side file (--explain=PATH); the detections are written as without it"
)


class ExplainWriteError(Exception):
    """The side file could not be written (a full disk, a closed device)."""

    def __init__(self, path: str, error: OSError) -> None:
        self.path = path
        super().__init__(f"writing {path}: {error.strerror or error}")


def bare_option_to_stderr(argv: Sequence[str]) -> list[str]:
    """A bare ``--explain`` made ``--explain=-`` before parsing, so that it never takes the next argument
    (a parameter file) as its path: a path is given only as ``--explain=PATH``."""
    args = list(argv)
    end = args.index("--") if "--" in args else len(args)
    return [f"{OPTION}={STDERR}" if i < end and a == OPTION else a for i, a in enumerate(args)]


class _SideFile:
    """The side file, its write errors raised as ExplainWriteError naming it (never as the OSError the run
    loop takes for a failure of the detections' output)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.stream = open_text_output(path)

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except OutputError:
            raise  # already names the file and keeps whole lines
        except OSError as exc:
            raise ExplainWriteError(self.path, exc) from None

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OutputError:
            raise  # already names the file and keeps whole lines
        except OSError as exc:
            raise ExplainWriteError(self.path, exc) from None

    def close(self) -> None:
        try:
            self.stream.close()
        except OutputError:
            raise  # already names the file and keeps whole lines
        except OSError as exc:
            raise ExplainWriteError(self.path, exc) from None


class Explainer:
    """Where ``--explain`` writes: the reason sink to give the director, and the side file to close."""

    def __init__(self, target: str, stderr: IO[str] | None = None) -> None:
        self._side = _SideFile(target) if target != STDERR else None
        self.sink = ReasonSink(self._side, "jsonl") if self._side else ReasonSink(stderr or sys.stderr, "text")

    @property
    def to_stderr(self) -> bool:
        return self._side is None

    def close(self) -> None:
        """Close the side file; a failure here (the last buffered bytes) is an ExplainWriteError too."""
        if self._side is not None:
            self._side.close()
