"""What the patrol needs of a robot, and nothing more: the surface :class:`~navigation.patrol.PatrolMachine`
and :func:`~navigation.runner.run_patrol` drive.

The built-in :class:`~navigation.simulation.Simulation` is one robot; a live ROS 1 robot (``objrec_apps``'
``Ros1Robot``, behind ``--robot ros1``) is another. Naming the surface as protocols keeps the state machine
the same for both: it sends goals to a move_base, starts and cancels the dock and undock actions, watches two
batteries, waits on a clock and reports to an event log. How the robot does those (simulated physics, or
actionlib topics over TCPROS) is its own business.

Two rules every robot keeps, because the machine relies on them:

- **Callbacks run on the patrol's thread, never re-entrantly.** A goal's or action's result, a timer and an
  event listener are called from :meth:`PatrolRobot.step`, never from inside ``send_goal``/``start_dock`` and
  never from another thread (a live robot hands what its network threads receive over to ``step``).
- **Time is the robot's clock.** ``clock.now`` is seconds since the robot was opened: simulated seconds for the
  simulator, wall-clock seconds for a live robot (then :attr:`PatrolRobot.wall_clock` is true, and the runner
  neither paces nor bounds the steps, since the world runs at its own speed).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from .events import EventLog
from .geometry import Pose2D
from .move_base import GoalStatus

#: A result callback of move_base and of the dock/undock actions: status and a text saying why.
ResultCallback = Callable[[GoalStatus, str], None]


@runtime_checkable
class TimerHandle(Protocol):
    """A timer that can be cancelled (:class:`navigation.clock.Timer` is one)."""

    def cancel(self) -> None: ...


@runtime_checkable
class PatrolClock(Protocol):
    """Timers on the robot's time; their callbacks run inside :meth:`PatrolRobot.step`."""

    @property
    def now(self) -> float: ...

    def call_later(self, delay: float, callback: Callable[[], None]) -> TimerHandle: ...

    def every(self, period: float, callback: Callable[[], None], first: float | None = None) -> TimerHandle: ...


@runtime_checkable
class GoalHandle(Protocol):
    """The goal move_base works on: the machine reads its name (``POSE_3``, ``MOVE_TO_STATION``)."""

    name: str


@runtime_checkable
class GoalClient(Protocol):
    """move_base as the patrol uses it: one goal at a time, a new one preempts the old one."""

    @property
    def active(self) -> bool: ...

    @property
    def goal(self) -> GoalHandle | None: ...

    def send_goal(self, pose: Pose2D, callback: ResultCallback | None = None, name: str = "") -> int: ...

    def cancel_goal(self, reason: str = "cancelled") -> None: ...


@runtime_checkable
class RobotAction(Protocol):
    """The dock or undock action while it runs; started through :meth:`PatrolRobot.start_dock`/``start_undock``."""

    @property
    def active(self) -> bool: ...

    def cancel(self) -> None: ...


@runtime_checkable
class BatteryView(Protocol):
    """A battery as the monitors read it."""

    @property
    def percentage(self) -> float: ...

    @property
    def is_low(self) -> bool: ...


@runtime_checkable
class RobotBatteryView(BatteryView, Protocol):
    """The robot's battery: WAIT_UNTIL_CHARGED also asks whether it is full. Crossing the low threshold is an
    event ``robot_battery`` with ``event`` ``BATTERY_LOW`` (or ``BATTERY_CRITICAL``) on the robot's log."""

    @property
    def is_full(self) -> bool: ...


@dataclass(frozen=True)
class RobotReport:
    """What a robot adds to the run's summary: how far it drove and how well it knew where it was."""

    distance: float = 0.0
    odometry_drift: float = 0.0
    collisions: int = 0
    localization: str = "exact"
    localization_error_mean: float = 0.0
    localization_error_max: float = 0.0
    localization_updates: int = 0


@runtime_checkable
class PatrolRobot(Protocol):
    """Everything the patrol machine and its runner use of a robot.

    ``dock_action`` is None when the robot cannot dock (no station): the machine then shuts down on a low
    battery instead of docking. ``halt`` is SHUTDOWN's: cancel every goal and action and stop the base.
    ``step`` advances the robot (one simulation step; for a live robot: wait briefly for messages and due
    timers) and runs the callbacks that are due. ``close`` releases what the robot holds (a live robot's
    connections) once the run is over; the events log stays open until its owner closes it.
    """

    clock: PatrolClock
    events: EventLog
    move_base: GoalClient
    robot_battery: RobotBatteryView
    laptop_battery: BatteryView

    @property
    def dock_action(self) -> RobotAction | None: ...

    @property
    def undock_action(self) -> RobotAction: ...

    @property
    def wall_clock(self) -> bool: ...

    def start_dock(self, callback: ResultCallback | None) -> None: ...

    def start_undock(self, callback: ResultCallback | None) -> None: ...

    def pose_estimate(self) -> Pose2D: ...

    def halt(self) -> None: ...

    def step(self) -> None: ...

    def report(self) -> RobotReport: ...

    def close(self) -> None: ...


#: The events the machine and move_base write on every robot, with the fields that must agree between robots
#: for the same outcomes (times, goal ids, poses and texts differ between a simulator and a real robot).
MACHINE_EVENT_FIELDS: dict[str, tuple[str, ...]] = {
    "state_enter": ("state",), "state_exit": ("state",), "goal_sent": ("name",), "goal_result": ("name", "status"),
    "action_result": ("action", "status"), "lap": ("laps",), "preempt_requested": ("reason",),
    "outcome": ("outcome",),
}


def machine_trace(events: list[dict[str, object]]) -> list[tuple[object, ...]]:
    """The robot-independent part of a run's events, in order: ``(type, field values...)`` for the kinds of
    :data:`MACHINE_EVENT_FIELDS`. Two robots that reach, abort and preempt the same goals give the same trace."""
    return [(e["type"], *(e.get(f) for f in MACHINE_EVENT_FIELDS[str(e["type"])]))
            for e in events if e["type"] in MACHINE_EVENT_FIELDS]
