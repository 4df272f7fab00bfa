"""move_base, docking and undocking of a live ROS 1 robot, as the patrol machine uses the simulator's.

They keep the simulator's rules (:mod:`navigation.move_base`, :mod:`navigation.docking`): one goal at a time,
a new goal preempts the running one, a cancelled goal ends at once as PREEMPTED (the server is told; what it
answers later is ignored), results reach the caller through the clock, never from inside ``send_goal``, and the
same events are written: ``goal_sent`` and ``goal_result`` for move_base goals, ``action_result`` for the dock
and undock actions. A goal the server does not acknowledge in time, or whose server goes silent, ends ABORTED
with the reason (:mod:`objrec_apps.ros1_actions`), and the patrol goes on as for any aborted goal.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable
from dataclasses import dataclass

from navigation.events import EventLog
from navigation.geometry import Pose2D, quaternion_from_yaw
from navigation.move_base import GoalStatus
from navigation.robot_interface import ResultCallback

from .ros1_actions import ActionClient
from .ros1_clock import WallClock

log = logging.getLogger(__name__)


@dataclass
class LiveGoal:
    """A goal sent to move_base: the patrol's number and name for it, and actionlib's id."""

    id: int
    name: str
    pose: Pose2D
    ros_id: str
    callback: ResultCallback | None
    status: GoalStatus = GoalStatus.ACTIVE


class LiveMoveBase:
    """move_base over its action topics (a :class:`navigation.robot_interface.GoalClient`)."""

    def __init__(self, action: ActionClient, clock: WallClock, events: EventLog, pose: Callable[[], Pose2D],
                 frame_id: str = "map") -> None:
        self.action = action
        self.clock = clock
        self.events = events
        self._pose = pose
        self.frame_id = frame_id
        self._ids = itertools.count(1)
        self.goal: LiveGoal | None = None

    @property
    def active(self) -> bool:
        return self.goal is not None and self.goal.status == GoalStatus.ACTIVE

    def send_goal(self, pose: Pose2D, callback: ResultCallback | None = None, name: str = "") -> int:
        """Send ``pose`` (map frame) to move_base; a running goal is preempted first, as move_base does."""
        if self.active:
            self.cancel_goal("preempted by a new goal")
        number = next(self._ids)
        qx, qy, qz, qw = quaternion_from_yaw(pose.yaw)
        target = {"header": {"frame_id": self.frame_id, "stamp": 0.0},
                  "pose": {"position": {"x": pose.x, "y": pose.y, "z": 0.0},
                           "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}}
        goal = LiveGoal(number, name, pose, "", callback)
        self.goal = goal
        label = f"goal {number} ({name})" if name else f"goal {number}"
        goal.ros_id = self.action.send({"target_pose": target}, lambda s, t: self._finish(goal, s, t), label)
        self.events.emit("goal_sent", goal_id=number, name=name, **pose.as_dict(), ros_id=goal.ros_id)
        return number

    def cancel_goal(self, reason: str = "cancelled") -> None:
        goal = self.goal
        if goal is not None and goal.status == GoalStatus.ACTIVE:
            self.action.cancel(goal.ros_id)
            self._finish(goal, GoalStatus.PREEMPTED, reason)

    def _finish(self, goal: LiveGoal, status: GoalStatus, text: str) -> None:
        if goal.status != GoalStatus.ACTIVE:
            return
        goal.status = status
        self.events.emit("goal_result", goal_id=goal.id, name=goal.name, status=status.value, text=text,
                         robot=self._pose().as_dict())
        log.info("goal %d (%s): %s %s", goal.id, goal.name, status.value, text)
        if goal.callback is not None:
            callback = goal.callback
            self.clock.call_later(0.0, lambda: callback(status, text))


class _ActionRun:
    """The dock or undock action while it runs: the result goes to the caller once, as an ``action_result``."""

    label = "Action"

    def __init__(self, clock: WallClock, events: EventLog) -> None:
        self.clock = clock
        self.events = events
        self.active = False
        self._run = 0
        self._callback: ResultCallback | None = None

    def _begin(self, callback: ResultCallback | None) -> int:
        self._run += 1
        self.active = True
        self._callback = callback
        return self._run

    def _finish(self, run: int, status: GoalStatus, text: str) -> None:
        if run != self._run or not self.active:
            return
        self.active = False
        self.events.emit("action_result", action=self.label, status=status.value, text=text)
        callback = self._callback
        if callback is not None:
            self.clock.call_later(0.0, lambda: callback(status, text))


class LiveDock(_ActionRun):
    """The Kobuki's auto-docking (``kobuki_msgs/AutoDocking``: an empty goal, a result ``text``)."""

    label = "DockAction"

    def __init__(self, action: ActionClient, clock: WallClock, events: EventLog) -> None:
        super().__init__(clock, events)
        self.action = action
        self._ros_id = ""

    def start(self, callback: ResultCallback | None) -> None:
        run = self._begin(callback)
        if not self.action.connected:
            self.clock.call_later(0.0, lambda: self._finish(
                run, GoalStatus.ABORTED, f"no docking action server at {self.action.namespace}"))
            return
        self._ros_id = self.action.send({}, lambda s, t: self._finish(run, s, t), "the docking goal")

    def cancel(self) -> None:
        if self.active:
            self.action.cancel(self._ros_id)
            self._finish(self._run, GoalStatus.PREEMPTED, "cancelled")


class UndockByGoal(_ActionRun):
    """Undocking as a short move_base goal back out to the station pose (the Kobuki has no undock action)."""

    label = "UndockAction"

    def __init__(self, move_base: LiveMoveBase, station_pose: Pose2D | None, clock: WallClock,
                 events: EventLog) -> None:
        super().__init__(clock, events)
        self.move_base = move_base
        self.station_pose = station_pose

    def start(self, callback: ResultCallback | None) -> None:
        run = self._begin(callback)
        if self.station_pose is None:
            self.clock.call_later(0.0, lambda: self._finish(run, GoalStatus.ABORTED, "no station pose to back out to"))
            return
        self.move_base.send_goal(self.station_pose, lambda s, t: self._finish(run, s, t), name="UNDOCK")

    def cancel(self) -> None:
        if self.active:
            goal = self.move_base.goal
            if goal is not None and goal.name == "UNDOCK":
                self.move_base.cancel_goal("cancelled")
            self._finish(self._run, GoalStatus.PREEMPTED, "cancelled")
