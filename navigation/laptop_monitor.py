"""The laptop on the robot, watched by a monitor that the patrol command adds.

In the thesis's setup a notebook rides on the TurtleBot and runs the patrol; when its battery runs low (below the
threshold and not charging) the run must end before the notebook dies. That is a fact about this set-up, not about
patrolling, so the machine does not know it: :func:`laptop_battery_monitor` is an ordinary
:class:`~navigation.patrol.Monitor`, added by ``objrec-patrol`` unless ``--laptop-plugged`` says the notebook is on
mains power. A program that builds :class:`~navigation.patrol.PatrolMachine` itself watches the laptop only if it
passes this monitor in ``monitors``. Like every added monitor it watches in every state (docked, charging,
LOCALIZE), so a laptop that runs low on the dock ends the run with that reason.
"""

from __future__ import annotations

import math

from .patrol import SHUTDOWN, Monitor
from .tasks import StateTask, TaskContext

#: The monitor's outcome, and the trigger that leads to SHUTDOWN.
LAPTOP_BATTERY_LOW = "laptop_battery_low"


def laptop_low_reason(percentage: float) -> str:
    """The run's end reason; the percentage is cut (not rounded) to one decimal, so it reads below the threshold
    as the battery was (19.96 % under a 20 % threshold reads 19.9, never 20.0)."""
    return f"laptop battery low ({math.floor(10.0 * percentage) / 10.0:.1f} %, not charging)"


class LaptopBatteryMonitor(StateTask):
    """Checks the robot's ``laptop_battery`` every ``period`` simulated seconds (at once on entering); ends with
    ``laptop_battery_low`` and the reason when it is low, i.e. below its threshold and not charging."""

    state = "LAPTOP_BATTERY_MONITOR"

    def __init__(self, period: float = 1.0) -> None:
        if not period > 0.0:
            raise ValueError(f"laptop battery monitor: period must be above 0 s, got {period!r}")
        self.period = period

    def start(self, ctx: TaskContext) -> None:
        def poll() -> None:
            battery = ctx.sim.laptop_battery
            if battery.is_low:
                ctx.finish(LAPTOP_BATTERY_LOW, laptop_low_reason(battery.percentage),
                           percentage=round(battery.percentage, 2))

        ctx.every(self.period, poll, first=0.0)

    def describe(self) -> str:
        return f"laptop battery, every {self.period:g} s"


def laptop_battery_monitor(period: float = 1.0) -> Monitor:
    """The monitor to pass to :class:`~navigation.patrol.PatrolMachine`: a low laptop battery ends the run."""
    return Monitor(LaptopBatteryMonitor(period), {LAPTOP_BATTERY_LOW: SHUTDOWN})
