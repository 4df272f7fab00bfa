"""What the objrec commands share: how a user mistake is reported, and where diagnostics go."""

from __future__ import annotations

import logging
import sys
from typing import IO

from strictio import OutputError
from strictio.atomic import LineOutput
from strictio.cli_numbers import Number
from strictio.shown import escape_controls, printable

#: Exit code for a mistake in what the user asked for (a bad file, source or option).
USER_ERROR = 2
#: The longest error line a command writes.
MESSAGE_LIMIT = 2000
#: How many frames --max-frames (objrec-detect, objrec-batch) may ask for.
MAX_FRAMES = Number(1, 1_000_000_000, whole=True)


class UserError(Exception):
    """A mistake in what the user asked for: reported in one line on stderr, exit code 2, no traceback."""


class EscapingFormatter(logging.Formatter):
    """Log lines whose message is shown escaped (strictio.shown): a warning naming a file or a source the
    user gave can neither split its line nor reorder the terminal's text. A traceback, when logged, keeps its
    lines."""

    def formatMessage(self, record: logging.LogRecord) -> str:  # noqa: N802 - logging's own name
        record.message = escape_controls(record.message)
        return super().formatMessage(record)


def configure_logging(prog: str, verbose: bool) -> None:
    """Diagnostics to stderr, prefixed with the command's name, escaped; stdout stays for results."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(EscapingFormatter(f"{prog}: %(levelname)s: %(message)s"))
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, handlers=[handler])


def report(prog: str, message: object) -> None:
    """One error line on stderr: control characters and bidirectional overrides in it (a name from a file, a
    source typed) are shown escaped (strictio.shown, the one place that decides), so that nothing can split
    the line, fake output or reorder what the terminal shows. Every error of a command is printed here."""
    sys.stderr.write(f"{prog}: error: {printable(message, limit=MESSAGE_LIMIT)}\n")


def open_text_output(path: str) -> IO[str]:
    """A text file a command streams into (JSON Lines, reasons), its missing parent folders made, that takes
    whole lines or nothing (strictio's LineOutput: a full disk is an OutputError and leaves no half line); one
    that cannot be opened is a UserError naming it."""
    try:
        return LineOutput.create(path, make_folders=True)  # type: ignore[return-value]
    except OutputError as exc:
        raise UserError(str(exc)) from None
