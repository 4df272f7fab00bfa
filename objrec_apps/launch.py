"""The commands' entry points: Ctrl-C or SIGTERM while a command's libraries load ends it with one line.

Importing a command loads NumPy, OpenCV and the rest: a few tenths of a second in which Python's own Ctrl-C
handling would print a KeyboardInterrupt traceback from deep inside some import. The console scripts start
here instead, and this module imports nothing heavy: a handler that ends the process at once (one line on
stderr, exit code 128 + the signal's number: 130 for Ctrl-C) is in place before the command's module is
imported, and the previous handling is back before its ``main`` runs, so that each command then treats
signals as it documents. Nothing is open or written yet at that point, so ending at once loses nothing.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from collections.abc import Callable, Iterator
from importlib import import_module
from types import FrameType

from strictio.signals import STOP_SIGNALS, handling

#: Each command's module (its ``main`` is the command).
COMMANDS = {
    "objrec-detect": "objrec_apps.detect",
    "objrec-define": "objrec_apps.define",
    "objrec-batch": "objrec_apps.batch",
    "objrec-inspect": "objrec_apps.inspect",
    "objrec-patrol": "navigation.cli",
    "objrec-eval": "objrec_apps.evaluate",
    "objrec-tune": "objrec_apps.tune",
}
#: The signals that end a command while it starts.
START_SIGNALS = STOP_SIGNALS


def _end_at_once(prog: str) -> Callable[[int, FrameType | None], None]:
    def handler(signum: int, _frame: FrameType | None) -> None:
        os.write(2, f"{prog}: interrupted while starting ({signal.Signals(signum).name})\n".encode())
        os._exit(128 + signum)

    return handler


@contextlib.contextmanager
def ending_at_once(prog: str, signals: tuple[int, ...] = START_SIGNALS) -> Iterator[None]:
    """Within: these signals end the process at once with one line (for a start-up that has nothing to save
    yet); the previous handling is back afterwards. Outside the main thread it changes nothing."""
    with handling(_end_at_once(prog), signals):
        yield


#: The optional libraries and the extra that installs each (pyproject.toml); a command that meets one missing,
#: at start or half way (the shape detector's scipy, objrec-batch's Dask), says which extra to install.
EXTRAS = {
    "scipy": "3d", "open3d": "3d", "pypcd4": "3d", "PySide6": "gui", "shiboken6": "gui", "rosbags": "ros",
    "cyclonedds": "ros2", "rerun": "viz", "foxglove": "viz", "dask": "batch", "distributed": "batch",
    "optuna": "tune",
}
#: Exit code of a missing extra: a user mistake, as every command documents it.
MISSING_EXTRA = 2


def missing_extra(exc: BaseException) -> tuple[str, str] | None:
    """(module, extra) when ``exc`` (or what it was raised from) is a missing module of an extra, else None."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        if isinstance(current, ModuleNotFoundError) and current.name:
            top = current.name.split(".", 1)[0]
            if top in EXTRAS:
                return top, EXTRAS[top]
        current = current.__cause__ or current.__context__
    return None


def launch(prog: str) -> int:
    """Import the command ``prog`` while a signal ends it at once, then run its ``main``; its exit code. A
    missing library of an extra, met anywhere in the command, is one line naming the extra, exit code 2."""
    try:
        with ending_at_once(prog):
            command = import_module(COMMANDS[prog])
        return int(command.main())
    except ImportError as exc:
        missing = missing_extra(exc)
        if missing is None:
            raise
        module, extra = missing
        sys.stderr.write(f"{prog}: error: {module} is not installed: it comes with the {extra} extra: "
                         f"pip install 'objrec[{extra}]'\n")
        return MISSING_EXTRA


def detect() -> int:
    return launch("objrec-detect")


def define() -> int:
    return launch("objrec-define")


def batch() -> int:
    return launch("objrec-batch")


def inspect() -> int:
    return launch("objrec-inspect")


def patrol() -> int:
    return launch("objrec-patrol")


def evaluate() -> int:
    return launch("objrec-eval")


def tune() -> int:
    return launch("objrec-tune")
