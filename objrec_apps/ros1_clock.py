"""The clock of a live robot: timers on real time, and an inbox through which network threads hand work over.

The patrol machine is single-threaded: its timers, results and event listeners must run on the thread that
runs the patrol (see :mod:`navigation.robot_interface`). A live robot's messages arrive on the transport's
threads, so they never touch the machine themselves: they :meth:`WallClock.post` a callable, and
:meth:`WallClock.run_pending`, called from the robot's ``step`` on the patrol's thread, runs what was posted and
the timers that are due. The timers are :class:`navigation.clock.Timer`, on seconds since the clock started,
with the same ``call_later``/``every`` as the simulator's clock.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import queue
import time
from collections.abc import Callable

from navigation.clock import Timer

log = logging.getLogger(__name__)


class WallClock:
    """Timers on the monotonic clock plus a thread-safe inbox; everything runs in :meth:`run_pending`."""

    def __init__(self, monotonic: Callable[[], float] = time.monotonic) -> None:
        self._monotonic = monotonic
        self._start = monotonic()
        self._timers: list[Timer] = []
        self._seq = itertools.count()
        self._inbox: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()

    @property
    def now(self) -> float:
        """Seconds since the clock started."""
        return self._monotonic() - self._start

    def call_at(self, when: float, callback: Callable[[], None]) -> Timer:
        timer = Timer(when, next(self._seq), callback)
        heapq.heappush(self._timers, timer)
        return timer

    def call_later(self, delay: float, callback: Callable[[], None]) -> Timer:
        return self.call_at(self.now + max(0.0, delay), callback)

    def every(self, period: float, callback: Callable[[], None], first: float | None = None) -> Timer:
        """Call ``callback`` every ``period`` seconds (first after ``first``, default one period)."""
        if period <= 0:
            raise ValueError(f"period must be positive, got {period}")
        timer = Timer(self.now + (period if first is None else first), next(self._seq), callback, period)
        heapq.heappush(self._timers, timer)
        return timer

    def post(self, callback: Callable[[], None]) -> None:
        """From any thread: run ``callback`` on the patrol's thread at the next :meth:`run_pending`."""
        self._inbox.put(callback)

    def _next_due(self) -> float | None:
        while self._timers and self._timers[0].cancelled:
            heapq.heappop(self._timers)
        return self._timers[0].due if self._timers else None

    def run_pending(self, max_wait: float) -> int:
        """Wait up to ``max_wait`` s for posted work or the next due timer, then run all posted work and every
        timer due by now (periodic ones re-armed); returns how many callbacks ran."""
        due = self._next_due()
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
        return ran + self._fire_due()

    def _fire_due(self) -> int:
        now = self.now + 1e-9
        ran = 0
        while self._timers and self._timers[0].due <= now:
            timer = heapq.heappop(self._timers)
            if timer.cancelled:
                continue
            if timer.period is not None:
                timer.due += timer.period
                if timer.due <= now:  # a stalled loop does not fire a periodic timer many times to catch up
                    timer.due = now + timer.period
                timer.seq = next(self._seq)
                heapq.heappush(self._timers, timer)
            timer.callback()
            ran += 1
        return ran
