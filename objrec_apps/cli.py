"""What the objrec commands share: how a user mistake is reported, and where diagnostics go."""

from __future__ import annotations

import logging
import sys
from typing import IO

from strictio import OutputError
from strictio.atomic import LineOutput
from strictio.cli_numbers import Number, printable

#: Exit code for a mistake in what the user asked for (a bad file, source or option).
USER_ERROR = 2
#: The longest error line a command writes.
MESSAGE_LIMIT = 2000
#: How many frames --max-frames (objrec-detect, objrec-batch) may ask for.
MAX_FRAMES = Number(1, 1_000_000_000, whole=True)


class UserError(Exception):
    """A mistake in what the user asked for: reported in one line on stderr, exit code 2, no traceback."""


def configure_logging(prog: str, verbose: bool) -> None:
    """Diagnostics to stderr, prefixed with the command's name; stdout stays for results."""
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING,
        format=f"{prog}: %(levelname)s: %(message)s",
        stream=sys.stderr,
    )


def report(prog: str, message: object) -> None:
    """One error line on stderr: control characters in it (a name from a file, a value typed) are shown
    escaped, so that nothing can split the line or fake output."""
    sys.stderr.write(f"{prog}: error: {printable(message, limit=MESSAGE_LIMIT)}\n")


def open_text_output(path: str) -> IO[str]:
    """A text file a command streams into (JSON Lines, reasons), its missing parent folders made, that takes
    whole lines or nothing (strictio's LineOutput: a full disk is an OutputError and leaves no half line); one
    that cannot be opened is a UserError naming it."""
    try:
        return LineOutput.create(path, make_folders=True)  # type: ignore[return-value]
    except OutputError as exc:
        raise UserError(str(exc)) from None
