"""What the objrec commands share: how a user mistake is reported, where diagnostics go, and the wrapper of every
command's ``main`` (exit codes for a mistake, Ctrl-C and a reader of stdout that went away)."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable
from typing import IO

from objrec_core import ParameterFileError, RecognitionSystem, UnknownModuleError, build_system
from strictio import OutputError
from strictio.atomic import LineOutput
from strictio.cli_numbers import Number, check_limit_settings
from strictio.shown import escape_controls, printable

from .launch import ending_at_once

#: Exit code for a mistake in what the user asked for (a bad file, source or option).
USER_ERROR = 2
#: Exit code after Ctrl-C (or SIGTERM) where a command stops without finishing, e.g. while starting.
INTERRUPTED = 130
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


def quiet_stdout(stdout: IO[str] | None = None) -> None:
    """After the reader of stdout went away (``| head``): point it at /dev/null, so that the interpreter's final
    flush stays quiet instead of printing a BrokenPipeError; what was written to files is complete."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, (sys.stdout if stdout is None else stdout).fileno())


def parse_and_run(prog: str, parser: argparse.ArgumentParser, argv: list[str] | None,
                  run: Callable[[argparse.Namespace, IO[str]], int]) -> int:
    """A command's usual start: its arguments parsed, logging set up (``--verbose``), the OBJREC_MAX_* limit
    variables checked, then ``run(args, sys.stdout)``. Until ``run`` a signal ends the command at once (nothing
    is open or written yet; see :mod:`.launch`)."""
    with ending_at_once(prog):
        args = parser.parse_args(argv)
        configure_logging(prog, args.verbose)
        check_limit_settings()
    return run(args, sys.stdout)


def run_command(prog: str, start: Callable[[], int], *,
                mistakes: tuple[type[Exception], ...] = (UserError,), interrupted: str = "interrupted") -> int:
    """Every command's ``main``: ``start()``'s exit code; one of ``mistakes`` is one error line and exit code 2;
    Ctrl-C not handled further in is ``{prog}: {interrupted}`` and 130; a reader of stdout that went away is
    not an error (exit 0, stdout quieted)."""
    try:
        return start()
    except mistakes as exc:
        report(prog, exc)
        return USER_ERROR
    except KeyboardInterrupt:
        sys.stderr.write(f"{prog}: {interrupted}\n")
        return INTERRUPTED
    except BrokenPipeError:
        quiet_stdout()
        return 0


def detecting_system(params: str) -> RecognitionSystem:
    """The system of a parameter file a command is to run: one that has a detector (else nothing would be
    detected) and a data kind; a file that cannot be built is a UserError naming it."""
    try:
        system = build_system(params)
    except (ParameterFileError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None
    if not system.detectors:
        raise UserError(f"{params}: pipeline: has no detector, so nothing would be detected")
    if not system.kind:
        raise UserError(f"{params}: kind: no module declares its data kind")
    return system
