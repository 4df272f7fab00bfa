"""Simulation time and timers that run on it.

Every wait in the patrol (battery polling, docking time-outs, recovery) is a timer on this clock rather
than a wall-clock thread, so a simulated hour takes seconds, runs are reproducible, and tests need no
sleeps.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass(order=True)
class Timer:
    """A callback due at ``due`` seconds of simulation time; cancel it to drop it."""

    due: float
    seq: int
    callback: Callable[[], None] = field(compare=False)
    period: float | None = field(default=None, compare=False)
    cancelled: bool = field(default=False, compare=False)

    def cancel(self) -> None:
        self.cancelled = True


class TimerQueue:
    """Timers in due order on a clock's :attr:`now`: the one home of ``call_at`` / ``call_later`` / ``every``
    and of firing what is due, shared by the simulator's clock and a live robot's wall clock (which differ only
    in what ``now`` is and in when they fire)."""

    #: A periodic timer that fell more than a period behind: False re-arms it one period on (it fires again in
    #: the same pass, once per period missed: in a simulation every period did happen); True re-arms it one
    #: period from now (a wall clock whose loop stalled does not fire it many times to catch up).
    skip_missed = False

    def __init__(self) -> None:
        self._timers: list[Timer] = []
        self._seq = itertools.count()

    @property
    def now(self) -> float:
        raise NotImplementedError

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

    def next_due(self) -> float | None:
        """When the earliest timer not cancelled is due (None: no timer)."""
        while self._timers and self._timers[0].cancelled:
            heapq.heappop(self._timers)
        return self._timers[0].due if self._timers else None

    def fire_due(self) -> int:
        """Run every timer due by now, in due order; periodic ones are re-armed. Returns how many ran."""
        now = self.now + 1e-9
        ran = 0
        while self._timers and self._timers[0].due <= now:
            timer = heapq.heappop(self._timers)
            if timer.cancelled:
                continue
            if timer.period is not None:
                timer.due += timer.period
                if self.skip_missed and timer.due <= now:
                    timer.due = now + timer.period
                timer.seq = next(self._seq)
                heapq.heappush(self._timers, timer)
            timer.callback()
            ran += 1
        return ran


class SimClock(TimerQueue):
    """Fixed-step simulation clock; :meth:`advance` moves it one step and fires the timers now due."""

    def __init__(self, dt: float = 0.1) -> None:
        if dt <= 0:
            raise ValueError(f"time step must be positive, got {dt}")
        super().__init__()
        self.dt = dt
        self.steps = 0

    @property
    def now(self) -> float:
        """Seconds since the start; counted in steps so that it never drifts by rounding."""
        return self.steps * self.dt

    def tick(self) -> None:
        """Move time on by one step without firing timers (the simulation fires them after physics)."""
        self.steps += 1

    def advance(self) -> None:
        self.tick()
        self.fire_due()
