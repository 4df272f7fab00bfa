"""The clock of a live robot: timers on real time, and an inbox through which network threads hand work over.

The patrol machine is single-threaded: its timers, results and event listeners must run on the thread that
runs the patrol (see :mod:`navigation.robot_interface`). A live robot's messages arrive on the transport's
threads, so they never touch the machine themselves: they :meth:`WallClock.post` a callable, and
:meth:`WallClock.run_pending`, called from the robot's ``step`` on the patrol's thread, runs what was posted and
the timers that are due. The timers are :class:`navigation.clock.TimerQueue`'s, on seconds since the clock started,
the same ``call_later``/``every`` as the simulator's clock.
"""

from __future__ import annotations

import logging
import queue
import time
from collections.abc import Callable

from navigation.clock import TimerQueue

log = logging.getLogger(__name__)


class WallClock(TimerQueue):
    """Timers on the monotonic clock plus a thread-safe inbox; everything runs in :meth:`run_pending`."""

    skip_missed = True  # a stalled loop does not fire a periodic timer many times to catch up

    def __init__(self, monotonic: Callable[[], float] = time.monotonic) -> None:
        super().__init__()
        self._monotonic = monotonic
        self._start = monotonic()
        self._inbox: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()

    @property
    def now(self) -> float:
        """Seconds since the clock started."""
        return self._monotonic() - self._start

    def post(self, callback: Callable[[], None]) -> None:
        """From any thread: run ``callback`` on the patrol's thread at the next :meth:`run_pending`."""
        self._inbox.put(callback)

    def run_pending(self, max_wait: float) -> int:
        """Wait up to ``max_wait`` s for posted work or the next due timer, then run all posted work and every
        timer due by now (periodic ones re-armed); returns how many callbacks ran."""
        due = self.next_due()
        wait = max_wait if due is None else min(max_wait, max(0.0, due - self.now))
        ran = 0
        try:
            first = self._inbox.get(timeout=wait) if wait > 0 else self._inbox.get_nowait()
        except queue.Empty:
            first = None
        if first is not None:
            first()
            ran += 1
        while True:
            try:
                work = self._inbox.get_nowait()
            except queue.Empty:
                break
            work()
            ran += 1
        return ran + self.fire_due()

