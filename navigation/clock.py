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


class SimClock:
    """Fixed-step simulation clock; :meth:`advance` moves it one step and fires the timers now due."""

    def __init__(self, dt: float = 0.1) -> None:
        if dt <= 0:
            raise ValueError(f"time step must be positive, got {dt}")
        self.dt = dt
        self.steps = 0
        self._timers: list[Timer] = []
        self._seq = itertools.count()

    @property
    def now(self) -> float:
        """Seconds since the start; counted in steps so that it never drifts by rounding."""
        return self.steps * self.dt

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

    def fire_due(self) -> None:
        """Run every timer due by now, in due order; periodic ones are re-armed."""
        now = self.now + 1e-9
        while self._timers and self._timers[0].due <= now:
            timer = heapq.heappop(self._timers)
            if timer.cancelled:
                continue
            if timer.period is not None:
                timer.due += timer.period
                timer.seq = next(self._seq)
                heapq.heappush(self._timers, timer)
            timer.callback()

    def tick(self) -> None:
        """Move time on by one step without firing timers (the simulation fires them after physics)."""
        self.steps += 1

    def advance(self) -> None:
        self.tick()
        self.fire_due()
