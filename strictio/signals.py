"""The one way the commands take over Ctrl-C (SIGINT) and SIGTERM, and give them back.

Every command ends on a signal without losing what it wrote: objrec-detect flushes its outputs, the patrol
ends in SHUTDOWN, objrec-batch still writes its summary. Each needs a different reaction (a flag polled
between frames or steps, KeyboardInterrupt, closing a window, ending at once while it starts), but all need
the same care around it: a handler can only be installed from the main thread, and the previous handling
must be back when the command's part is over (tests and embedding programs run commands in-process). That
care lives here once; it is in the floor because the navigation stack may not import the apps.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any

#: The signals a command treats as "stop": Ctrl-C in a terminal and a polite kill (systemd, docker stop).
STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)

#: What ``signal.signal`` takes: a function, or ``signal.SIG_IGN`` / ``signal.SIG_DFL``.
Handler = Callable[[int, FrameType | None], Any] | int | signal.Handlers


@contextlib.contextmanager
def handling(handler: Handler, signals: tuple[int, ...] = STOP_SIGNALS) -> Iterator[None]:
    """Within: ``handler`` (a function, or ``signal.SIG_IGN``) receives ``signals``; afterwards the previous
    handling is back, also when the block raised. Outside the main thread, where Python allows no handler, it
    changes nothing.

    A signal ignored when the block begins stays ignored: a shell starts a background job (``cmd &`` in a
    script) with Ctrl-C ignored, so that Ctrl-C at the terminal is not for it; taking the signal over for part
    of the run only would make a Ctrl-C count in some phases and vanish in others. SIGTERM, which a shell does
    not ignore for its jobs, still stops such a run."""
    previous: dict[int, Any] = {}
    if threading.current_thread() is threading.main_thread():
        for sig in signals:
            if signal.getsignal(sig) is signal.SIG_IGN:
                continue
            previous[sig] = signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def raise_interrupt(_signum: int, _frame: FrameType | None) -> None:
    """A handler that makes a signal (SIGTERM) act as Ctrl-C does by default: KeyboardInterrupt."""
    raise KeyboardInterrupt


class StopSignals:
    """Turns the first SIGINT or SIGTERM into a stop request, a flag polled between frames or steps, so the
    work ends at a clean point with its outputs written; a second one raises KeyboardInterrupt, since the work
    itself may be stuck.

    ``reason`` is the first signal's name, ``count`` how many came, ``event`` is set on the first (for loops
    that wait on it). ``escalate`` names the signals that give up on a second arrival: all of them by default;
    objrec-detect lets only Ctrl-C do it, so that a repeated SIGTERM from a supervisor still ends cleanly.
    A context manager: the handlers are in place within it only (nothing outside the main thread).
    """

    def __init__(self, escalate: tuple[int, ...] = STOP_SIGNALS) -> None:
        self.count = 0
        self.reason = ""
        self.event = threading.Event()
        self._escalate = escalate
        self._handling: contextlib.ExitStack | None = None

    def __enter__(self) -> StopSignals:
        stack = contextlib.ExitStack()
        stack.enter_context(handling(self._handle))
        self._handling = stack
        return self

    def __exit__(self, *_exc: object) -> None:
        if self._handling is not None:
            self._handling.close()
            self._handling = None

    def _handle(self, signum: int, _frame: FrameType | None) -> None:
        self.count += 1
        if self.count > 1 and signum in self._escalate:
            raise KeyboardInterrupt
        self.reason = self.reason or signal.Signals(signum).name
        self.event.set()
