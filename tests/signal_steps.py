"""Real signals at known moments, for the tests of how the commands end on Ctrl-C and SIGTERM.

Two moments matter: during start-up (a signal sent from inside a function the command calls while it loads,
so it arrives exactly there), and while the command runs (a child process signalled once it shows it is at
work). Both send a real signal through the kernel, never a simulated KeyboardInterrupt.
"""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Callable
from types import ModuleType
from typing import Any

import pytest

#: How long a child may take to show it is at work or to end: a hang guard, never a speed bound.
HANG_GUARD = 180.0


def signal_during(monkeypatch: pytest.MonkeyPatch, module: ModuleType, name: str, sig: int) -> None:
    """Make ``module.name`` send ``sig`` to this process before doing its real work."""
    real = getattr(module, name)

    def signalled(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), sig)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, signalled)


def signal_once_working(argv: list[str], working: Callable[[], bool], sig: int, after: float) -> tuple[int, str, str]:
    """Start ``argv``, wait until ``working()`` says it is at work, let it run ``after`` seconds more, send
    ``sig``; its exit code, stdout and stderr. The child is killed if it hangs."""
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + HANG_GUARD
        while not working() and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.05)
        time.sleep(after)
        process.send_signal(sig)
        out, err = process.communicate(timeout=HANG_GUARD)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    return process.returncode, out, err
