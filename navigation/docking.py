"""The docking station and the dock/undock actions (the Kobuki's ``dock_drive_action``, simplified).

The real auto-docking follows the dock's infrared beams, which only reach a robot standing in front of
the dock and turned towards it. So the dock action here succeeds when the robot starts close to the dock,
inside the cone in front of it and facing it; it then creeps forward onto the contacts and charging
starts. From anywhere else it searches (turns slowly) for a while and aborts, as a robot that sees no
beam would.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

from .geometry import Pose2D, wrap_angle
from .move_base import GoalStatus

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DockingStation:
    """The dock's contacts at (x, y); ``yaw`` points out of the dock, towards an approaching robot."""

    pose: Pose2D

    @staticmethod
    def in_front_of(station_pose: Pose2D, distance: float = 1.0) -> DockingStation:
        """The dock ``distance`` metres ahead of the station pose, facing back at it."""
        ahead = station_pose.ahead(distance)
        return DockingStation(Pose2D(ahead.x, ahead.y, wrap_angle(station_pose.yaw + math.pi)))

    def docked_pose(self, robot_radius: float) -> Pose2D:
        """Where the robot's centre is when its front touches the contacts, facing the dock."""
        out = self.pose.ahead(robot_radius)
        return Pose2D(out.x, out.y, wrap_angle(self.pose.yaw + math.pi))


@dataclass(frozen=True)
class DockParams:
    max_distance: float = 1.6
    max_bearing: float = math.radians(35.0)
    max_heading_error: float = math.radians(40.0)
    approach_speed: float = 0.1
    search_time: float = 20.0
    search_speed: float = 0.3
    undock_distance: float = 0.5
    undock_speed: float = 0.1


ActionCallback = Callable[[GoalStatus, str], None]


class _Action:
    """What the dock and undock actions share: a result delivered once to whoever started them."""

    def __init__(self) -> None:
        self._callback: ActionCallback | None = None
        self._result: tuple[GoalStatus, str] | None = None

    def take_result(self) -> tuple[ActionCallback | None, GoalStatus, str] | None:
        """The finished result once (for the simulation to deliver), else None."""
        if self._result is None:
            return None
        status, text = self._result
        self._result = None
        return self._callback, status, text


class DockAction(_Action):
    """Drives onto the dock; :meth:`control` gives (v, w) each step until it reports its result."""

    def __init__(self, station: DockingStation, robot_radius: float, params: DockParams | None = None) -> None:
        super().__init__()
        self.station = station
        self.radius = robot_radius
        self.params = params or DockParams()
        self.active = False
        self.searching = False
        self.docked = False
        self._elapsed = 0.0
        self._why = ""

    def can_see_dock(self, pose: Pose2D) -> tuple[bool, str]:
        """Whether the dock's beams reach the robot: in range, in front of the dock, robot facing it."""
        p, dock = self.params, self.station.pose
        dx, dy = pose.x - dock.x, pose.y - dock.y
        dist = math.hypot(dx, dy)
        if dist > p.max_distance:
            return False, f"dock is {dist:.2f} m away (beams reach {p.max_distance:g} m)"
        bearing = abs(wrap_angle(math.atan2(dy, dx) - dock.yaw)) if dist > 1e-6 else 0.0
        if bearing > p.max_bearing:
            return False, f"robot is {math.degrees(bearing):.0f} deg off the dock's axis"
        facing = abs(wrap_angle(math.atan2(-dy, -dx) - pose.yaw)) if dist > 1e-6 else 0.0
        if facing > p.max_heading_error:
            return False, f"robot faces {math.degrees(facing):.0f} deg away from the dock"
        return True, ""

    def start(self, pose: Pose2D, callback: ActionCallback | None) -> None:
        self.active = True
        self.docked = False
        self._elapsed = 0.0
        self._callback = callback
        self._result = None
        ok, why = self.can_see_dock(pose)
        self.searching = not ok
        self._why = why

    def cancel(self) -> None:
        if self.active:
            self._finish(GoalStatus.PREEMPTED, "cancelled")

    def _finish(self, status: GoalStatus, text: str) -> None:
        self.active = False
        self.searching = False
        self._result = (status, text)

    def control(self, pose: Pose2D, dt: float, collided: bool) -> tuple[float, float]:
        if not self.active:
            return 0.0, 0.0
        p = self.params
        self._elapsed += dt
        if self.searching:
            if self._elapsed >= p.search_time:
                self._finish(GoalStatus.ABORTED, f"no dock signal: {self._why}")
                return 0.0, 0.0
            return 0.0, p.search_speed
        if collided:
            self._finish(GoalStatus.ABORTED, "bumped into something on the way to the dock")
            return 0.0, 0.0
        target = self.station.docked_pose(self.radius)
        dist = math.hypot(target.x - pose.x, target.y - pose.y)
        if dist < 0.02:
            self.docked = True
            self._finish(GoalStatus.SUCCEEDED, "docked")
            return 0.0, 0.0
        if self._elapsed > 3.0 * p.max_distance / p.approach_speed:
            self._finish(GoalStatus.ABORTED, "timed out approaching the dock")
            return 0.0, 0.0
        alpha = wrap_angle(math.atan2(target.y - pose.y, target.x - pose.x) - pose.yaw)
        v = min(p.approach_speed, dist / dt) * max(0.0, math.cos(alpha))
        return v, 2.0 * alpha


class UndockAction(_Action):
    """Backs straight off the dock so the robot can turn and drive away."""

    def __init__(self, params: DockParams | None = None) -> None:
        super().__init__()
        self.params = params or DockParams()
        self.active = False
        self._start: Pose2D | None = None
        self._elapsed = 0.0

    def start(self, pose: Pose2D, callback: ActionCallback | None) -> None:
        self.active = True
        self._start = pose
        self._callback = callback
        self._result = None
        self._elapsed = 0.0

    def cancel(self) -> None:
        if self.active:
            self.active = False
            self._result = (GoalStatus.PREEMPTED, "cancelled")

    def control(self, pose: Pose2D, dt: float, collided: bool) -> tuple[float, float]:
        if not self.active or self._start is None:
            return 0.0, 0.0
        p = self.params
        self._elapsed += dt
        if collided:
            self.active = False
            self._result = (GoalStatus.ABORTED, "bumped into something while backing off the dock")
            return 0.0, 0.0
        if pose.distance_to(self._start) >= p.undock_distance:
            self.active = False
            self._result = (GoalStatus.SUCCEEDED, "undocked")
            return 0.0, 0.0
        if self._elapsed > 3.0 * p.undock_distance / p.undock_speed:
            self.active = False
            self._result = (GoalStatus.ABORTED, "could not back off the dock")
            return 0.0, 0.0
        return -p.undock_speed, 0.0
