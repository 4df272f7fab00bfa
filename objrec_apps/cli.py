"""What the objrec commands share: how a user mistake is reported, and where diagnostics go."""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from typing import IO

#: Exit code for a mistake in what the user asked for (a bad file, source or option).
USER_ERROR = 2


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
    """One error line on stderr."""
    sys.stderr.write(f"{prog}: error: {message}\n")


def open_text_output(path: str) -> IO[str]:
    """A text file a command streams into (JSON Lines, reasons), its missing parent folders made; one that
    cannot be opened is a UserError naming it."""
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        return target.open("w", encoding="utf-8")
    except OSError as exc:
        raise UserError(f"{path}: cannot be written: {exc.strerror or exc}") from None
