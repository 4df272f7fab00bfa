"""A move_base-like goal interface: send a goal pose, cancel it, get SUCCEEDED, ABORTED or PREEMPTED.

It plans with :class:`~navigation.planner.Planner` on the map, drives with
:class:`~navigation.follower.PathFollower`, and, given a laser (``scan_source``), keeps a
:class:`~navigation.local_costmap.LocalCostmap` of what is in the way that the map does not show. When
such an obstacle comes within reach of the path the robot is following, or the next moment of the
commanded motion would touch one, the robot stops and plans again with those obstacles added, as
move_base's global planner does on a costmap with an obstacle layer.

Like move_base it runs recovery behaviours when there is no path or the robot stops making progress:
clear the costmap (forget what the laser marked), rotate in place (look all round), back up (away from
what it is pressed against); each runs at most once per goal, in that order, and a behaviour that could
change nothing (clearing an empty costmap, backing into an obstacle) is skipped. A fourth, ``wait`` (Nav2's
Wait behaviour), runs where ``recovery_behaviours`` lists it (:data:`PATIENT_RECOVERY_BEHAVIOURS`): it stands
still up to ``patience`` seconds, scanning, and drives on as soon as a plan round what the laser marked
exists again (a person who stopped in the way moves on). Once it faces the way, each of its scans keeps only
what the laser sees and what lies within ``keep_near`` of the robot (``LocalCostmap.refresh``): a mark farther out
of view is a walker's trail, which no beam clears while the robot stands, and a wait for a way round it waits for
nobody; one beside the robot may be a person standing there.
After the last behaviour it gives up with ABORTED, so a goal that makes no progress ends after a bounded
simulated time whatever the time step. Progress means the path still to drive getting shorter: a robot
circling its goal moves but makes none. A goal inside an obstacle or off the map is aborted at once: no
recovery can make it reachable. Results are delivered through the simulation clock, never from inside
:meth:`MoveBase.send_goal`, so a caller is never re-entered.
"""

from __future__ import annotations

import enum
import itertools
import logging
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .clock import SimClock
from .costmap import ObstacleField
from .events import EventLog
from .follower import FollowerParams, PathFollower
from .geometry import Pose2D, wrap_angle
from .laser import LaserParams, LaserScan
from .local_costmap import LocalCostmap, LocalCostmapParams
from .planner import Plan, Planner

log = logging.getLogger(__name__)

RECOVERY_BEHAVIOURS = ("clear_costmap", "rotate", "back_up")
#: Every behaviour ``recovery_behaviours`` may list: the default ones and ``wait``.
KNOWN_RECOVERY_BEHAVIOURS = (*RECOVERY_BEHAVIOURS, "wait")
#: The order with a wait for what stands in the way to move, before the robot turns and backs away.
PATIENT_RECOVERY_BEHAVIOURS = ("clear_costmap", "wait", "rotate", "back_up")
#: Plans kept for inspection: a patrol of hours makes hundreds of thousands, and each holds its path.
KEPT_PLANS = 100

# Plan failures no recovery behaviour can help with: the goal is aborted at once.
_HOPELESS = ("goal is in an obstacle", "goal is outside", "start is outside", "goal is in a keepout zone")


class GoalStatus(enum.Enum):
    PENDING = "PENDING"
    ACTIVE = "ACTIVE"
    SUCCEEDED = "SUCCEEDED"
    ABORTED = "ABORTED"
    PREEMPTED = "PREEMPTED"


ResultCallback = Callable[[GoalStatus, str], None]
ScanSource = Callable[[], LaserScan]


@dataclass(frozen=True)
class MoveBaseParams:
    """Progress, recovery and avoidance settings.

    ``stuck_timeout`` seconds in which the path still to drive does not shrink by ``progress_distance``
    count as no progress. ``recovery_behaviours`` run in order, each at most once per goal (names from
    :data:`KNOWN_RECOVERY_BEHAVIOURS`); ``wait`` stands still for at most ``patience`` seconds, scanning as
    often as when it watches a blocked way (keeping, once it faces the way, only the marks in view or close by),
    and ends as soon as a plan exists; the rotation turns
    ``recovery_turn`` radians at ``recovery_speed``; the
    back-up drives ``backup_distance`` metres backwards at ``backup_speed``, for at most
    ``backup_distance / backup_speed + backup_slack`` seconds. The way counts as blocked where the path
    passes closer than the robot's radius plus ``blocked_margin`` to an obstacle the laser marked; the
    motion of the next ``safety_time`` seconds (and at least one step) must keep ``safety_margin`` clear.
    A blocked way first stops the robot for ``look_time`` seconds of scans: if the way clears, it drives on;
    if meanwhile something seen before has gone (cells cleared: what blocks the way is moving), it waits
    up to ``yield_time`` seconds for it to pass; otherwise, or then, it plans round what is marked.

    A collision-monitor style guard works beside that: while the robot drives forward it reads the laser into
    the costmap (counted apart, in ``LocalCostmap.monitor_scans``) every step while something marked is within
    the marking range, else every quarter of the update distance, so what comes towards it is seen at once,
    not at the next scheduled scan; the speed is capped so
    that the robot can stop ``stop_gap`` metres short of the first marked cell its swept footprint would touch
    (braking at half ``linear_accel``, and no faster than ``max_linear`` times the free distance over
    ``slow_distance``), a marked cell ahead of the robot (in front of its axle) within ``slow_zone`` metres of
    its body holds it to ``slow_speed``, rising to full speed ``slow_distance`` farther out (a slowdown zone:
    passing a person close by happens at a walk), and the
    robot never moves off from a standstill without a fresh scan.
    """

    stuck_timeout: float = 10.0
    progress_distance: float = 0.1
    recovery_behaviours: tuple[str, ...] = RECOVERY_BEHAVIOURS
    recovery_turn: float = 2.0 * math.pi
    recovery_speed: float = 1.0
    backup_distance: float = 0.3
    backup_speed: float = 0.1
    backup_slack: float = 2.0
    blocked_margin: float = 0.05
    safety_margin: float = 0.02
    safety_time: float = 0.5
    look_time: float = 1.0
    yield_time: float = 5.0
    slow_distance: float = 1.0
    stop_gap: float = 0.05
    slow_zone: float = 0.3
    slow_speed: float = 0.2
    patience: float = 15.0
    local_costmap: LocalCostmapParams = field(default_factory=LocalCostmapParams)

    def __post_init__(self) -> None:
        unknown = [b for b in self.recovery_behaviours if b not in KNOWN_RECOVERY_BEHAVIOURS]
        if unknown:
            raise ValueError(f"unknown recovery behaviour(s) {unknown}; known: {list(KNOWN_RECOVERY_BEHAVIOURS)}")
        if not self.patience >= 0:
            raise ValueError(f"patience must be zero or positive seconds, got {self.patience}")

    def no_progress_bound(self, dt: float) -> float:
        """Longest simulated time a goal can last after its last progress before it is aborted.

        Every behaviour may be followed by a full ``stuck_timeout`` (waiting for a blocked way counts in
        it, replanning does not restart it); each phase can end up to one step late.
        """
        behaviours = self.recovery_behaviours
        t = (len(behaviours) + 1) * (self.stuck_timeout + dt)
        if "rotate" in behaviours:
            t += self.recovery_turn / self.recovery_speed + dt
        if "back_up" in behaviours:
            t += self.backup_distance / self.backup_speed + self.backup_slack + dt
        if "wait" in behaviours:
            t += self.patience + dt
        return t


@dataclass
class _Goal:
    id: int
    pose: Pose2D
    name: str
    callback: ResultCallback | None
    status: GoalStatus = GoalStatus.PENDING


@dataclass
class _Behaviour:
    """A recovery behaviour that moves the base, in progress."""

    name: str
    left: float  # radians still to turn, or metres still to back up
    start: Pose2D
    deadline: float
    seen: int = -1  # wait: the costmap version last planned on
    heading: float | None = None  # wait: where to face, the way the map's path leaves (None: facing it)


class MoveBase:
    """One active goal at a time; :meth:`control` is called every simulation step for the velocity command.

    ``scan_source`` (a callable returning a :class:`LaserScan` taken where the robot is; the costmap places
    it at the pose move_base drives on) turns on the local costmap; set it after construction, or with
    :meth:`use_laser`. Without it the robot drives on the map alone, and finds unmapped obstacles only by
    running into them.
    """

    def __init__(self, planner: Planner, clock: SimClock, events: EventLog,
                 follower_params: FollowerParams | None = None, params: MoveBaseParams | None = None,
                 pose_source: Callable[[], Pose2D] | None = None, scan_source: ScanSource | None = None) -> None:
        self.planner = planner
        self.clock = clock
        self.events = events
        self.follower_params = follower_params or FollowerParams()
        # Speed zones' cap on each command (navigation.costmap_filters.SpeedZones.cap), set by whoever builds it.
        self.speed_limit: Callable[[Pose2D, float, float, float], tuple[float, float]] | None = None
        self.params = params or MoveBaseParams()
        self._pose_source = pose_source
        self.scan_source = scan_source
        self.costmap = LocalCostmap(planner.field, self.params.local_costmap)
        self._ids = itertools.count(1)
        self.goal: _Goal | None = None
        self.follower: PathFollower | None = None
        self.last_plan: Plan | None = None
        self.plans: deque[Plan] = deque(maxlen=KEPT_PLANS)  # the latest, for a look after a run
        self._recoveries = 0
        self._next_behaviour = 0
        self._behaviour: _Behaviour | None = None
        self._best_to_go = math.inf
        self._check_time = 0.0
        self._scan_pose: Pose2D | None = None
        self._scan_time = -math.inf
        self._fast_until = -math.inf
        self._stop_version = -1
        self._waiting = False  # stopped in front of a blocked way, watching it
        self._wait_start = 0.0
        self._wait_moving = False  # something near has moved since the wait began
        self._avoid_planner: tuple[int, Planner] | None = None
        self._last_v = 0.0  # the last linear command: zero means the next forward one moves off from a standstill
        self._monitor_pose: Pose2D | None = None  # where the guard last read the laser
        self.slowed = 0  # steps the guard capped the speed
        self.guard_stops = 0  # steps the guard stopped the robot short of a marked cell
        self.counts = {s: 0 for s in (GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.PREEMPTED)}

    def use_laser(self, scan: Callable[[LaserParams], LaserScan], laser: LaserParams) -> None:
        """Take scans for the costmap from ``scan`` (called with laser parameters, e.g. ``Simulation.scan``).

        The costmap asks for no more than ``local_costmap.beams`` beams and no farther than its clearing
        range: what lies beyond changes nothing in it, and a shorter, sparser scan costs less.
        """
        c = self.params.local_costmap
        costmap_laser = replace(laser, beams=min(laser.beams, c.beams),
                                range_max=min(laser.range_max, max(c.raytrace_range, c.obstacle_range)))
        self.scan_source = lambda: scan(costmap_laser)

    @property
    def active(self) -> bool:
        return self.goal is not None and self.goal.status == GoalStatus.ACTIVE

    @property
    def last_progress(self) -> float:
        """Simulation time of the current goal's last progress (or of its last plan after a recovery)."""
        return self._check_time

    @property
    def recovering(self) -> str | None:
        """The recovery behaviour moving the base now, if any."""
        return self._behaviour.name if self._behaviour is not None else None

    # -- client side --------------------------------------------------------------------------------
    def send_goal(self, pose: Pose2D, callback: ResultCallback | None = None, name: str = "") -> int:
        """Start driving to ``pose``; an active goal is preempted first, as move_base does."""
        if self.active:
            self._finish(GoalStatus.PREEMPTED, "preempted by a new goal")
        goal = _Goal(next(self._ids), pose, name, callback, GoalStatus.ACTIVE)
        self.goal = goal
        self._recoveries = 0
        self._next_behaviour = 0
        self.events.emit("goal_sent", goal_id=goal.id, name=name, **pose.as_dict())
        if self.scan_source is not None and self._scan_pose is None:
            self._sense(self._pose(), True, force=True)  # the first goal: look before planning
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
        self._behaviour = None
        self._waiting = False
        self.counts[status] += 1
        robot = self._pose_source().as_dict() if self._pose_source is not None else {}
        self.events.emit("goal_result", goal_id=goal.id, name=goal.name, status=status.value, text=text,
                         robot=robot)
        log.info("goal %d (%s): %s %s", goal.id, goal.name, status.value, text)
        if goal.callback is not None:
            callback = goal.callback
            self.clock.call_later(0.0, lambda: callback(status, text))

    def _clearance(self) -> float:
        return self.planner.params.robot_radius + self.params.blocked_margin

    def _planner_round_obstacles(self) -> Planner:
        """A planner on the map plus the marked cells, built once per state of the costmap."""
        version = self.costmap.version
        if self._avoid_planner is None or self._avoid_planner[0] != version:
            planner = Planner(ObstacleField(self.costmap.as_map()), replace(self.planner.params, landmarks=0))
            self._avoid_planner = (version, planner)
        return self._avoid_planner[1]

    def _make_plan(self) -> tuple[Plan, int]:
        """A plan from where the robot is, round what the laser marked when the map's path runs into it; and how
        many marked cells it had to avoid."""
        goal = self.goal
        assert goal is not None
        start = self._pose()
        tolerance = self.follower_params.xy_tolerance
        plan = self.planner.plan(start, goal.pose, tolerance)
        avoiding = 0
        if plan.ok and self.costmap.blocking(plan.path, self._clearance()) is not None:
            # The map's path runs into something the laser has seen: plan round what is marked.
            avoiding = len(self.costmap)
            plan = self._planner_round_obstacles().plan(start, goal.pose, tolerance)
            if not plan.ok and plan.reason.startswith("goal is in an obstacle"):
                plan.reason = "goal is blocked by an obstacle the map does not show"
            elif not plan.ok and plan.reason.startswith("start is in an obstacle"):
                plan.reason = "the robot is hemmed in by obstacles the map does not show"
            elif not plan.ok and plan.reason.startswith("no path"):
                plan.reason = "no path round the obstacles the map does not show"
        return plan, avoiding

    def _plan(self, restart_clock: bool = True) -> None:
        """Plan from where the robot is; ``restart_clock=False`` keeps the no-progress clock running."""
        goal = self.goal
        assert goal is not None
        plan, avoiding = self._make_plan()
        self.last_plan = plan
        self.plans.append(plan)
        self.events.emit("plan", goal_id=goal.id, ok=plan.ok, length=round(plan.length, 3),
                         ms=round(plan.seconds * 1000.0, 2), reason=plan.reason, avoiding=avoiding)
        self._waiting = False
        if plan.ok:
            self.follower = PathFollower(plan.path, goal.pose, self.follower_params)
            self._reset_progress(self.follower.to_go, restart_clock)
        elif plan.reason.startswith(_HOPELESS):
            self._finish(GoalStatus.ABORTED, plan.reason)
        elif avoiding and self.clock.now < self._fast_until and not self._stuck():
            # What closes the way has just moved (a person): watch it as a blocked way rather than recover, within
            # the no-progress time (the clock keeps running, so this cannot go on for ever).
            self.follower = None
            self._waiting, self._wait_start, self._wait_moving = True, self.clock.now, True
        else:
            self.follower = None
            self._recover(plan.reason)

    def _recover(self, why: str) -> None:
        """Start the next recovery behaviour that can change something, or abort when none is left."""
        goal = self.goal
        assert goal is not None
        self.follower = None
        self._waiting = False
        pose = self._pose()
        behaviours = self.params.recovery_behaviours
        while self._next_behaviour < len(behaviours):
            name = behaviours[self._next_behaviour]
            self._next_behaviour += 1
            if name == "clear_costmap":
                if self.costmap.empty:
                    log.debug("goal %d: nothing to clear, clear_costmap skipped", goal.id)
                    continue
                self._recoveries += 1
                # Forget only what the laser does not see now: a walker still standing there stays marked.
                scan = self.scan_source() if self.scan_source is not None else None
                cleared = self.costmap.clear(pose, scan)
                self.events.emit("recovery", goal_id=goal.id, attempt=self._recoveries, reason=why,
                                 behaviour=name, cleared=cleared, kept=len(self.costmap))
                self._plan()  # instantaneous: plan again at once
                return
            if name == "rotate":
                self._recoveries += 1
                self._behaviour = _Behaviour(name, self.params.recovery_turn, pose, math.inf)
                self.events.emit("recovery", goal_id=goal.id, attempt=self._recoveries, reason=why,
                                 behaviour=name)
                return
            if name == "wait":
                if self.costmap.empty or self.params.patience <= 0:
                    log.debug("goal %d: nothing marked that could move away, wait skipped", goal.id)
                    continue
                self._recoveries += 1
                self._behaviour = _Behaviour(name, 0.0, pose, self.clock.now + self.params.patience,
                                             self.costmap.version, self._way_heading(pose))
                self.events.emit("recovery", goal_id=goal.id, attempt=self._recoveries, reason=why,
                                 behaviour=name, patience=self.params.patience)
                return
            if name == "back_up":
                room = self._room_behind(pose)
                if room < 0.5 * self.planner.field.resolution:
                    log.debug("goal %d: no room behind the robot, back_up skipped", goal.id)
                    continue
                self._recoveries += 1
                p = self.params
                self._behaviour = _Behaviour(name, room, pose,
                                             self.clock.now + room / p.backup_speed + p.backup_slack)
                self.events.emit("recovery", goal_id=goal.id, attempt=self._recoveries, reason=why,
                                 behaviour=name, distance=round(room, 3))
                return
        self._finish(GoalStatus.ABORTED, f"{why} (after {self._recoveries} recovery attempts)")

    def _way_heading(self, pose: Pose2D) -> float | None:
        """The heading of the map's path one metre out from ``pose`` (towards the goal without one): where a
        waiting robot looks, so that its laser sees, and clears, what blocks the way rather than a wall."""
        goal = self.goal
        assert goal is not None
        plan = self.planner.plan(pose, goal.pose, self.follower_params.xy_tolerance)
        tx, ty = goal.pose.x, goal.pose.y
        if plan.ok and len(plan.path) > 1:
            d = np.hypot(plan.path[:, 0] - pose.x, plan.path[:, 1] - pose.y)
            far = np.nonzero(d >= 1.0)[0]
            tx, ty = plan.path[far[0] if len(far) else -1]
        if math.hypot(tx - pose.x, ty - pose.y) < 1e-6:
            return None
        return math.atan2(ty - pose.y, tx - pose.x)

    def _room_behind(self, pose: Pose2D) -> float:
        """How far (up to ``backup_distance``) the robot can back up without touching anything known.

        The laser looks forward only, so behind the robot the map and the marks made earlier are all there is.
        """
        radius = self.planner.params.robot_radius + self.params.safety_margin
        step = self.planner.field.resolution
        room = 0.0
        while room + step <= self.params.backup_distance + 1e-9:
            p = pose.ahead(-(room + step))
            if self.planner.field.collides(p.x, p.y, radius) or not self.costmap.disc_free(p.x, p.y, radius):
                break
            room += step
        return room

    def _stuck(self) -> bool:
        return self.clock.now - self._check_time >= self.params.stuck_timeout - 1e-9

    def _reset_progress(self, to_go: float, restart_clock: bool = True) -> None:
        self._best_to_go = to_go
        if restart_clock:
            self._check_time = self.clock.now

    # -- sensing ------------------------------------------------------------------------------------
    def _sense(self, pose: Pose2D, heading_matters: bool, force: bool = False) -> bool:
        """Read the laser when the robot has moved, turned or waited enough; True when it did.

        A turn counts only when ``heading_matters``: before driving forward in the new direction, or while
        a recovery turns the robot to look round. Turning in place to a goal's heading needs no scans.
        """
        p = self.costmap.params
        last = self._scan_pose
        if not force and last is not None:
            watching = self._waiting or (self._behaviour is not None and self._behaviour.name == "wait")
            rate = p.fast_rate if watching or self.clock.now < self._fast_until else 1.0
            turned = heading_matters and abs(wrap_angle(pose.yaw - last.yaw)) * rate >= p.update_angle
            if (not turned and pose.distance_to(last) * rate < p.update_distance
                    and (self.clock.now - self._scan_time) * rate < p.update_period):
                return False
        assert self.scan_source is not None
        self._scan_pose, self._scan_time = pose, self.clock.now
        b = self._behaviour
        if b is not None and b.name == "wait" and b.heading is None:
            # Standing and facing the way: what is out of view and not close by is a trail (see refresh).
            self.costmap.refresh(pose, self.scan_source())
        else:
            self.costmap.update(pose, self.scan_source())
        if self.costmap.last_cleared:
            self._fast_until = self.clock.now + p.update_period  # something moved: keep an eye on it
        return True

    def _check_way(self, pose: Pose2D) -> None:
        """After a scan: is the path ahead, within the local window, still free of marked obstacles?"""
        if self._waiting and self.costmap.last_cleared:
            self._wait_moving = True
        hit = None
        if self.follower is not None and not self.costmap.empty:
            ahead = np.vstack([[pose.x, pose.y], self.follower.ahead()])
            hit = self.costmap.blocking(ahead, self._clearance(), 0.5 * self.costmap.params.window)
        if hit is None:
            if self._waiting and self.follower is not None:  # without a path, only a new plan ends the wait
                self._end_wait()
        elif not self._waiting:
            self._blocked(hit)

    def _blocked(self, hit: tuple[float, float, float]) -> None:
        """The way is blocked at ``hit``: stop and watch it for a moment, or plan round it at once."""
        assert self.goal is not None
        x, y, along = hit
        wait = self.params.look_time > 0 and not self._waiting
        self.events.emit("path_blocked", goal_id=self.goal.id, x=round(x, 3), y=round(y, 3),
                         ahead=round(along, 3), obstacles=len(self.costmap), action="wait" if wait else "replan")
        log.info("goal %d: way blocked %.2f m ahead at (%.2f, %.2f); %s", self.goal.id, along, x, y,
                 "stopping to watch it" if wait else "planning again")
        if wait:
            self._waiting, self._wait_start = True, self.clock.now
            self._wait_moving = self.costmap.last_cleared > 0
            return
        # A detour is not a fresh start: the no-progress clock keeps running, so replanning cannot go on forever.
        self._plan(restart_clock=False)

    def _end_wait(self) -> None:
        assert self.goal is not None
        self.events.emit("path_clear", goal_id=self.goal.id, waited=round(self.clock.now - self._wait_start, 3))
        self._waiting = False

    def _wait_over(self) -> bool:
        """Whether the watch over a blocked way has lasted long enough to plan round what blocks it."""
        p = self.params
        return self.clock.now - self._wait_start >= (p.yield_time if self._wait_moving else p.look_time) - 1e-9

    def _arc(self, pose: Pose2D, v: float, w: float, horizon: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points every half cell along the arc (v, w) drives from ``pose`` for ``horizon`` metres: (s, x, y)."""
        n = max(2, math.ceil(horizon / (0.5 * self.planner.field.resolution)) + 1)
        s = np.linspace(0.0, horizon, n)
        if abs(w) < 1e-6:
            return s, pose.x + s * math.cos(pose.yaw), pose.y + s * math.sin(pose.yaw)
        r = v / w
        yaw = pose.yaw + s / r
        return s, pose.x + r * (np.sin(yaw) - math.sin(pose.yaw)), pose.y - r * (np.cos(yaw) - math.cos(pose.yaw))

    def _motion_hit(self, pose: Pose2D, v: float, w: float, dt: float) -> tuple[float, float, float] | None:
        """Where the commanded arc of the next moments would bring the robot too close to a marked cell."""
        if v <= 0.0:
            return None
        horizon = v * max(self.params.safety_time, dt) + v * v / (2.0 * self.follower_params.linear_accel)
        radius = self.planner.params.robot_radius + self.params.safety_margin
        cells = self.costmap.near(pose.x, pose.y, horizon + radius + self.planner.field.resolution)
        if not len(cells):
            return None
        s, xs, ys = self._arc(pose, v, w, horizon)
        d = self.costmap.distance(xs, ys, cells)
        closer = (d < radius) & (d < d[0] - 1e-6)  # moving away from something already close is fine
        if not closer.any():
            return None
        k = int(np.argmax(closer))
        return float(xs[k]), float(ys[k]), float(s[k])

    # -- control ------------------------------------------------------------------------------------
    def control(self, pose: Pose2D, dt: float) -> tuple[float, float]:
        """Velocity command for this step (zero when idle)."""
        v, w = self._control(pose, dt)
        if self.speed_limit is not None:
            v, w = self.speed_limit(pose, v, w, dt)
        self._last_v = v
        return v, w

    def _control(self, pose: Pose2D, dt: float) -> tuple[float, float]:
        if not self.active:
            return 0.0, 0.0
        sensing = self.scan_source is not None
        if sensing and self._sense(pose, self._behaviour is not None) and self._behaviour is None:
            self._check_way(pose)
            if not self.active:
                return 0.0, 0.0
        if self._behaviour is not None:
            return self._recovery_step(pose, dt)
        if self._waiting:
            if self._stuck():  # waiting is no progress either
                self._recover(f"no progress for {self.params.stuck_timeout:g} s")
                return 0.0, 0.0
            if not self._wait_over():
                return 0.0, 0.0
            self._plan(restart_clock=False)  # it is still there: plan round it
            if not self.active or self.follower is None:
                return 0.0, 0.0
        if self.follower is None:
            return 0.0, 0.0
        v, w, done = self.follower.command(pose, dt)
        if done:
            self._finish(GoalStatus.SUCCEEDED, "goal reached")
            return 0.0, 0.0
        if sensing and v > 0.0 and self._sense(pose, True):  # about to drive where it has not looked
            self._check_way(pose)
            if self._waiting or self.follower is None or not self.active:
                return 0.0, 0.0
        looked = False
        if sensing and v > 0.0 and self._scan_time < self.clock.now - 1e-9:
            if self._last_v <= 0.0:
                looked = self._sense(pose, True, force=True)  # moving off: a full look first
            elif self._monitor_due(pose):
                assert self.scan_source is not None
                self._monitor_pose = pose
                # the collision monitor's sensor rate
                self.costmap.update(pose, self.scan_source(), monitor=True)
                looked = True
        if looked:
            self._check_way(pose)
            if self._waiting or self.follower is None or not self.active:
                return 0.0, 0.0
        if not self.costmap.empty and v > 0.0:
            v = self._guard_speed(pose, v, w, dt)
        if not self.costmap.empty:
            hit = self._motion_hit(pose, v, w, dt)
            if hit is not None:
                # Stop short of it: the way is blocked (once per state of the costmap). Turning in place is safe.
                if self._stop_version != self.costmap.version:
                    self._stop_version = self.costmap.version
                    self._blocked(hit)
                    return 0.0, 0.0
                v = 0.0
        to_go = self.follower.to_go
        if to_go <= self._best_to_go - self.params.progress_distance:
            self._reset_progress(to_go)
        elif self._stuck():
            self._recover(f"no progress for {self.params.stuck_timeout:g} s")
            return 0.0, 0.0
        return v, w

    def _guard_speed(self, pose: Pose2D, v: float, w: float, dt: float) -> float:
        """``v`` capped so the robot can stop ``stop_gap`` short of the first marked cell its sweep would touch,
        and slowed towards ``slow_speed`` as a marked cell ahead comes within ``slow_zone`` of its body."""
        p = self.params
        horizon = max(p.slow_distance, v * dt + v * v / self.follower_params.linear_accel)
        free = self._free_along(pose, v, w, horizon)
        near = self._nearest_ahead(pose)
        top = self.follower_params.max_linear
        cap = p.slow_speed + (top - p.slow_speed) * min(1.0, max(0.0, near - p.slow_zone) / p.slow_distance)
        if free < horizon:
            room = max(0.0, free - p.stop_gap)
            cap = min(cap, math.sqrt(self.follower_params.linear_accel * room),
                      self.follower_params.max_linear * room / p.slow_distance, room / dt)
        if cap < v:
            self.slowed += 1
            if cap <= 1e-3:
                self.guard_stops += 1
                return 0.0
            return cap
        return v

    def _monitor_due(self, pose: Pose2D) -> bool:
        """Whether the guard reads the laser now: every step while a mark lies within the marking range, else
        after a quarter of the costmap's update distance (what walks in then is seen 2 m off, not 0.5 m)."""
        c = self.costmap.params
        if self._monitor_pose is None or len(self.costmap.near(pose.x, pose.y, c.obstacle_range)):
            return True
        return pose.distance_to(self._monitor_pose) * c.fast_rate >= c.update_distance

    def _nearest_ahead(self, pose: Pose2D) -> float:
        """Distance from the robot's body to the nearest marked cell in front of its axle (inf when none near)."""
        reach = self.planner.params.robot_radius + self.params.slow_zone + 1.0
        cells = self.costmap.near(pose.x, pose.y, reach)
        if not len(cells):
            return math.inf
        dx, dy = cells[:, 0] - pose.x, cells[:, 1] - pose.y
        ahead = dx * math.cos(pose.yaw) + dy * math.sin(pose.yaw) > 0.0
        if not ahead.any():
            return math.inf
        d = np.hypot(dx[ahead], dy[ahead]) - 0.5 * self.planner.field.resolution
        return float(d.min()) - self.planner.params.robot_radius

    def _free_along(self, pose: Pose2D, v: float, w: float, horizon: float) -> float:
        """How far the robot can go along the arc of (v, w) before its disc (plus ``safety_margin``) touches a
        marked cell it is not already moving away from; ``horizon`` when nothing is in reach."""
        radius = self.planner.params.robot_radius + self.params.safety_margin
        cells = self.costmap.near(pose.x, pose.y, horizon + radius + self.planner.field.resolution)
        if not len(cells):
            return horizon
        s, xs, ys = self._arc(pose, v, w, horizon)
        d = self.costmap.distance(xs, ys, cells)
        closer = (d < radius) & (d < d[0] - 1e-6)
        return float(s[int(np.argmax(closer))]) if closer.any() else horizon

    def _recovery_step(self, pose: Pose2D, dt: float) -> tuple[float, float]:
        b = self._behaviour
        assert b is not None
        p = self.params
        if b.name == "wait":
            # Face the way, then stand still; after each scan that changed the costmap, look for a way again
            # (without a plan event). Turning on the spot touches nothing.
            turn = 0.0
            if b.heading is not None:
                error = wrap_angle(b.heading - pose.yaw)
                if abs(error) > 0.05:
                    turn = math.copysign(min(p.recovery_speed, abs(error) / dt), error)
                else:
                    b.heading = None
            if self.clock.now >= b.deadline - 1e-9:
                self._behaviour = None
                self._plan()  # the patience is spent: the plan's failure starts the next behaviour
                return 0.0, 0.0
            if self.costmap.version != b.seen:
                b.seen = self.costmap.version
                if self._make_plan()[0].ok:
                    self._behaviour = None
                    self._plan()
                    return 0.0, 0.0
            return 0.0, turn
        if b.name == "rotate":
            turn = min(p.recovery_speed * dt, b.left)
            b.left -= turn
            if b.left <= 1e-9:
                self._behaviour = None
                self._plan()
            return 0.0, p.recovery_speed
        # back_up: until the distance is covered (a bump may stop the base) or the time allowed is up.
        left = b.left - pose.distance_to(b.start)
        if left <= 0.2 * p.backup_speed * dt or self.clock.now >= b.deadline - 1e-9:
            self._behaviour = None
            self._plan()
            return 0.0, 0.0
        return -min(p.backup_speed, left / dt), 0.0
