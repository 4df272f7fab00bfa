"""A move_base-like goal interface: send a goal pose, cancel it, get SUCCEEDED, ABORTED or PREEMPTED.

It plans with :class:`~navigation.planner.Planner`, drives with :class:`~navigation.follower.PathFollower`
and, like move_base, tries recovery behaviours (a rotation in place, then a new plan) a bounded number of
times when there is no path or the robot stops making progress, before it gives up with ABORTED. A goal
inside an obstacle or off the map is aborted at once: no recovery can make it reachable. Results are
delivered through the simulation clock, never from inside :meth:`MoveBase.send_goal`, so a caller is never
re-entered.
"""

from __future__ import annotations

import enum
import itertools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

from .clock import SimClock
from .events import EventLog
from .follower import FollowerParams, PathFollower
from .geometry import Pose2D, wrap_angle
from .planner import Plan, Planner

log = logging.getLogger(__name__)


class GoalStatus(enum.Enum):
    PENDING = "PENDING"
    ACTIVE = "ACTIVE"
    SUCCEEDED = "SUCCEEDED"
    ABORTED = "ABORTED"
    PREEMPTED = "PREEMPTED"


ResultCallback = Callable[[GoalStatus, str], None]


@dataclass(frozen=True)
class MoveBaseParams:
    """Recovery and progress settings; ``stuck_timeout`` seconds without progress count as stuck."""

    max_recoveries: int = 2
    stuck_timeout: float = 10.0
    progress_distance: float = 0.1
    progress_angle: float = 0.3
    recovery_turn: float = 2.0 * math.pi
    recovery_speed: float = 1.0


@dataclass
class _Goal:
    id: int
    pose: Pose2D
    name: str
    callback: ResultCallback | None
    status: GoalStatus = GoalStatus.PENDING


class MoveBase:
    """One active goal at a time; :meth:`control` is called every simulation step for the velocity command."""

    def __init__(self, planner: Planner, clock: SimClock, events: EventLog,
                 follower_params: FollowerParams | None = None, params: MoveBaseParams | None = None,
                 pose_source: Callable[[], Pose2D] | None = None) -> None:
        self.planner = planner
        self.clock = clock
        self.events = events
        self.follower_params = follower_params or FollowerParams()
        self.params = params or MoveBaseParams()
        self._pose_source = pose_source
        self._ids = itertools.count(1)
        self.goal: _Goal | None = None
        self.follower: PathFollower | None = None
        self.last_plan: Plan | None = None
        self.plans: list[Plan] = []
        self._recoveries = 0
        self._recovering_left = 0.0
        self._check_pose: Pose2D | None = None
        self._check_time = 0.0
        self.counts = {s: 0 for s in (GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.PREEMPTED)}

    @property
    def active(self) -> bool:
        return self.goal is not None and self.goal.status == GoalStatus.ACTIVE

    # -- client side --------------------------------------------------------------------------------
    def send_goal(self, pose: Pose2D, callback: ResultCallback | None = None, name: str = "") -> int:
        """Start driving to ``pose``; an active goal is preempted first, as move_base does."""
        if self.active:
            self._finish(GoalStatus.PREEMPTED, "preempted by a new goal")
        goal = _Goal(next(self._ids), pose, name, callback, GoalStatus.ACTIVE)
        self.goal = goal
        self._recoveries = 0
        self.events.emit("goal_sent", goal_id=goal.id, name=name, **pose.as_dict())
        self._plan()
        return goal.id

    def cancel_goal(self, reason: str = "cancelled") -> None:
        if self.active:
            self._finish(GoalStatus.PREEMPTED, reason)

    # -- internals ----------------------------------------------------------------------------------
    def _pose(self) -> Pose2D:
        if self._pose_source is None:
            raise RuntimeError("MoveBase needs a pose source")
        return self._pose_source()

    def _finish(self, status: GoalStatus, text: str) -> None:
        goal = self.goal
        if goal is None or goal.status != GoalStatus.ACTIVE:
            return
        goal.status = status
        self.follower = None
        self._recovering_left = 0.0
        self.counts[status] += 1
        robot = self._pose_source().as_dict() if self._pose_source is not None else {}
        self.events.emit("goal_result", goal_id=goal.id, name=goal.name, status=status.value, text=text,
                         robot=robot)
        log.info("goal %d (%s): %s %s", goal.id, goal.name, status.value, text)
        if goal.callback is not None:
            callback = goal.callback
            self.clock.call_later(0.0, lambda: callback(status, text))

    def _plan(self) -> None:
        goal = self.goal
        assert goal is not None
        start = self._pose()
        plan = self.planner.plan(start, goal.pose, self.follower_params.xy_tolerance)
        self.last_plan = plan
        self.plans.append(plan)
        self.events.emit("plan", goal_id=goal.id, ok=plan.ok, length=round(plan.length, 3),
                         ms=round(plan.seconds * 1000.0, 2), reason=plan.reason)
        if plan.ok:
            self.follower = PathFollower(plan.path, goal.pose, self.follower_params)
            self._reset_progress(start)
        elif plan.reason.startswith(("goal is in an obstacle", "goal is outside", "start is outside")):
            self._finish(GoalStatus.ABORTED, plan.reason)
        else:
            self._recover(plan.reason)

    def _recover(self, why: str) -> None:
        if self._recoveries >= self.params.max_recoveries:
            self._finish(GoalStatus.ABORTED, f"{why} (after {self._recoveries} recovery attempts)")
            return
        self._recoveries += 1
        self.follower = None
        self._recovering_left = self.params.recovery_turn
        assert self.goal is not None
        self.events.emit("recovery", goal_id=self.goal.id, attempt=self._recoveries, reason=why,
                         behaviour="rotate_recovery")

    def _reset_progress(self, pose: Pose2D) -> None:
        self._check_pose = pose
        self._check_time = self.clock.now

    def control(self, pose: Pose2D, dt: float) -> tuple[float, float]:
        """Velocity command for this step (zero when idle)."""
        if not self.active:
            return 0.0, 0.0
        if self._recovering_left > 0.0:
            turn = min(self.params.recovery_speed * dt, self._recovering_left)
            self._recovering_left -= turn
            if self._recovering_left <= 1e-9:
                self._recovering_left = 0.0
                self._plan()
            return 0.0, self.params.recovery_speed
        if self.follower is None:
            return 0.0, 0.0
        v, w, done = self.follower.command(pose)
        if done:
            self._finish(GoalStatus.SUCCEEDED, "goal reached")
            return 0.0, 0.0
        check = self._check_pose
        if check is not None and (pose.distance_to(check) >= self.params.progress_distance
                                  or abs(wrap_angle(pose.yaw - check.yaw)) >= self.params.progress_angle):
            self._reset_progress(pose)
        elif self.clock.now - self._check_time >= self.params.stuck_timeout:
            self._recover(f"no progress for {self.params.stuck_timeout:g} s")
            return 0.0, 0.0
        return v, w
