"""How long one call of a checked plug-in may take: CPU time, not wall-clock time.

A frame that takes ten seconds of wall-clock time on a machine shared with other work may take one second
of CPU: a limit on wall-clock time fails healthy modules on a busy machine and passes slow ones on an idle
one. So the limit is the CPU time of the thread doing the work (read from outside while it runs, so a
runaway call is stopped being waited for as soon as it passes the limit); wall-clock time is only a hang
guard, minutes long, for a call that blocks without using the CPU.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")

#: Wall-clock seconds a call may take at the least before it counts as hung, whatever its CPU limit.
HANG_SECONDS = 120.0
#: How often the CPU time of a running call is read.
POLL_SECONDS = 0.02


class CPULimitExceeded(AssertionError):
    """A call used more CPU time than allowed (``used`` seconds), or hung (``hung``)."""

    def __init__(self, message: str, used: float, hung: bool = False) -> None:
        super().__init__(message)
        self.used = used
        self.hung = hung


def hang_seconds(cpu_seconds: float) -> float:
    """The wall-clock hang guard for a call allowed ``cpu_seconds`` of CPU: generous, minutes at least."""
    return max(HANG_SECONDS, 20.0 * cpu_seconds)


def _thread_clock(thread: threading.Thread) -> Callable[[], float] | None:
    """A reader of another thread's CPU time, where the platform has one (POSIX thread CPU clocks)."""
    get_id = getattr(time, "pthread_getcpuclockid", None)
    if get_id is None or thread.ident is None:
        return None
    try:
        clock = get_id(thread.ident)
    except (OSError, OverflowError):
        return None
    return lambda: time.clock_gettime(clock)


def call_with_cpu_limit(work: Callable[[], T], cpu_seconds: float, *, name: str = "check") -> tuple[T, float]:
    """``work()`` in a worker thread; its result and the CPU seconds it used. CPULimitExceeded when it uses
    more than ``cpu_seconds`` of CPU (its own thread's; the whole process's where threads have no clock of
    their own) or runs ``hang_seconds`` of wall-clock time. An exception of ``work`` is raised here.

    Python cannot stop a thread: a call over the limit goes on in the background (a daemon thread) while the
    check fails at once."""
    outcome: dict[str, Any] = {}
    started, go = threading.Event(), threading.Event()

    def run() -> None:
        started.set()
        go.wait()  # until the checking thread has read this thread's clock: it is alive while that is read
        begin = time.thread_time()
        try:
            outcome["result"] = work()
        except BaseException as exc:  # handed to the checking thread
            outcome["error"] = exc
        outcome["cpu"] = time.thread_time() - begin

    worker = threading.Thread(target=run, name=name, daemon=True)
    process_start = time.process_time()
    wall_start = time.monotonic()
    worker.start()
    started.wait()
    thread_clock = _thread_clock(worker)
    thread_start = thread_clock() if thread_clock is not None else 0.0
    go.set()
    guard = hang_seconds(cpu_seconds)
    while True:
        worker.join(POLL_SECONDS)
        if not worker.is_alive():
            break
        try:
            used = (thread_clock() - thread_start) if thread_clock is not None else time.process_time() - process_start
        except OSError:  # the thread ended between the two calls
            continue
        if used > cpu_seconds:
            raise CPULimitExceeded(f"took more than {cpu_seconds:g} s of CPU time (still running)", used)
        if time.monotonic() - wall_start > guard:
            raise CPULimitExceeded(f"hung: no result after {guard:g} s of wall-clock time, {used:.1f} s of it CPU",
                                   used, hung=True)
    if "error" in outcome:
        raise outcome["error"]
    used = outcome["cpu"]
    if used > cpu_seconds:
        raise CPULimitExceeded(f"took {used:.2f} s of CPU time, more than {cpu_seconds:g} s", used)
    return outcome["result"], used
