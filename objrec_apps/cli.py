"""What the objrec commands share: how a user mistake is reported, and where diagnostics go."""

from __future__ import annotations

import logging
import sys

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
