"""The in-process simulator that replaces Stage, amcl and the Kobuki driver for the patrol.

One :meth:`Simulation.step` advances the world by a fixed time step: the active action (move_base, dock
or undock) computes a velocity command, the base moves within its limits unless that would hit an
obstacle (then it stops and the bump is counted once), odometry and both batteries are updated, and the
clock fires whatever timers are due. What pose move_base drives on depends on ``SimConfig.localization``:
the true pose (``exact``, the default, as if amcl had converged), the estimate of an amcl-like particle
filter matching laser scans to the map (``amcl``), or odometry alone (``odometry``); see
:mod:`navigation.localization`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from .battery import LaptopBattery, LaptopBatteryParams, RobotBattery, RobotBatteryParams
from .clock import SimClock
from .costmap import ObstacleField
from .docking import ActionCallback, DockAction, DockingStation, DockParams, UndockAction
from .events import EventLog
from .follower import FollowerParams
from .geometry import Pose2D, wrap_angle
from .laser import LaserParams, LaserScan, cast_scan
from .localization import AmclParams, Localizer, make_localizer
from .maps import OccupancyMap
from .move_base import MoveBase, MoveBaseParams
from .planner import Planner, PlannerParams
from .robot import DiffDriveRobot, Odometry, RobotParams
from .robot_interface import RobotReport
from .walkers import Crowd
from .world import World

log = logging.getLogger(__name__)


# A bump is counted once; the contact ends when the robot is this far clear of the obstacle again, so
# pushing against a wall (stop, creep, stop) is one collision, not one per step.
CONTACT_RELEASE = 0.05


class StartPoseError(ValueError):
    """The robot cannot start where it was asked to (off the map or inside an obstacle); the message names the
    file that puts something there: the map file, or the world file and its objects on the pose."""


def _start_refusal(occ_map: OccupancyMap, world: World | None, start: Pose2D, radius: float) -> str:
    """Why the robot cannot start at ``start``: the map (off it, or in one of its obstacles), else the things of
    the world that stand there."""
    where = f"start pose ({start.x:.3f}, {start.y:.3f}) puts the robot (radius {radius:g} m)"
    inside = world.colliding(start.x, start.y, radius) if world is not None else []
    if world is not None and inside:
        names = ", ".join(repr(name) for name in inside)
        return f"{world.source or 'the world'}: {where} inside an obstacle of the world: {names}"
    return f"{occ_map.source or 'the map'}: {where} off the map or inside an obstacle"


@dataclass(frozen=True)
class SimConfig:
    """Everything tunable about a run; the defaults describe a TurtleBot 2 with a Kobuki base."""

    dt: float = 0.1
    robot: RobotParams = field(default_factory=RobotParams)
    inflation_margin: float = 0.10
    follower: FollowerParams = field(default_factory=FollowerParams)
    move_base: MoveBaseParams = field(default_factory=MoveBaseParams)
    robot_battery: RobotBatteryParams = field(default_factory=RobotBatteryParams)
    robot_battery_percent: float = 100.0
    laptop_battery: LaptopBatteryParams = field(default_factory=LaptopBatteryParams)
    laptop_battery_percent: float = 100.0
    laptop_plugged: bool = False
    dock: DockParams = field(default_factory=DockParams)
    odom_linear_noise: float = 0.0
    odom_angular_noise: float = 0.0
    laser: LaserParams = field(default_factory=LaserParams)
    lethal_threshold: int = 65
    unknown_is_obstacle: bool = True
    seed: int = 0
    record_every: int = 1  # keep the trajectory every N steps for pictures; 0 keeps none
    localization: str = "exact"  # "exact" (true pose), "amcl" (particle filter on laser scans), "odometry"
    amcl: AmclParams = field(default_factory=AmclParams)
    # The global planner's settings (cost shape, keepout cells: navigation.nav_params sets them); None: the robot's
    # radius and ``inflation_margin`` with the planner's defaults. The simulation builds its planner once from them.
    planner: PlannerParams | None = None

    def planner_params(self) -> PlannerParams:
        """What the simulation's planner is built with."""
        if self.planner is not None:
            return self.planner
        return PlannerParams(robot_radius=self.robot.radius, inflation_margin=self.inflation_margin)


class Simulation:
    """World, robot, batteries, dock and move_base on one simulation clock.

    It is the built-in :class:`~navigation.robot_interface.PatrolRobot` (``--robot sim``): the patrol drives it
    through that protocol only, so a live robot can take its place.
    """

    #: Simulated time: the runner may run it flat out (bounded in steps) or paced to the wall clock.
    wall_clock = False

    def __init__(self, occ_map: OccupancyMap, start: Pose2D, config: SimConfig | None = None,
                 station: DockingStation | None = None, field_: ObstacleField | None = None,
                 planner: Planner | None = None, world: World | None = None) -> None:
        self.config = cfg = config or SimConfig()
        self.map = occ_map
        self.clock = SimClock(cfg.dt)
        self.events = EventLog(lambda: self.clock.now)
        self.rng = np.random.default_rng(cfg.seed)
        self.field = field_ or ObstacleField(occ_map, cfg.lethal_threshold, cfg.unknown_is_obstacle)
        # Objects and obstacles the map does not have: solid and seen by the laser. The simulation steps its own
        # live copy, whose walkers record where they really went (they stop or step aside for the robot).
        self.world = world.live() if world is not None else None
        self.crowd = Crowd(self.world, lambda x, y, r: not self._collides_static(x, y, r)) \
            if self.world is not None else None
        radius = cfg.robot.radius
        if self._collides(start.x, start.y, radius):
            raise StartPoseError(_start_refusal(occ_map, self.world, start, radius))
        self.planner = planner or Planner(self.field, cfg.planner_params())
        self.start = start
        self.robot = DiffDriveRobot(start, cfg.robot)
        self.odom = Odometry(cfg.odom_linear_noise, cfg.odom_angular_noise, self.rng)
        # The filter matches scans against what the map says (the planner's field), not the world's.
        self.localizer: Localizer | None = make_localizer(
            cfg.localization, field=self.planner.field, start=start, scan=self.scan, laser=cfg.laser,
            params=cfg.amcl, rng=np.random.default_rng([cfg.seed, 1]), events=self.events,
            now=lambda: self.clock.now)
        self.move_base = MoveBase(self.planner, self.clock, self.events, cfg.follower, cfg.move_base,
                                  pose_source=self.pose_estimate)
        self.move_base.use_laser(self.scan, cfg.laser)  # the local costmap sees what the map does not show
        self.robot_battery = RobotBattery(self.events, cfg.robot_battery, cfg.robot_battery_percent)
        self.laptop_battery = LaptopBattery(self.events, cfg.laptop_battery, cfg.laptop_battery_percent,
                                            cfg.laptop_plugged)
        self.station = station
        self.dock_action = DockAction(station, radius, cfg.dock) if station else None
        self.undock_action = UndockAction(cfg.dock)
        self.collisions = 0
        self.in_contact = False
        self.distance = 0.0
        self.trajectory: list[tuple[float, float, float, float]] = [(0.0, start.x, start.y, start.yaw)]
        self.collision_points: list[tuple[float, float]] = []
        self.docked = False
        self.halted = False
        # A velocity command used when no action drives the robot, like keyboard teleop in a
        # mapping chapter; tests use it to drive the base by hand.
        self.teleop: tuple[float, float] | None = None

    # -- actions ------------------------------------------------------------------------------------
    def start_dock(self, callback: ActionCallback | None) -> None:
        if self.dock_action is None:
            raise RuntimeError("no docking station in this simulation")
        self.move_base.cancel_goal("docking")
        self.dock_action.start(self.robot.pose, callback)

    def start_undock(self, callback: ActionCallback | None) -> None:
        self.undock_action.start(self.robot.pose, callback)

    def halt(self) -> None:
        """Stop everything and the base: what SHUTDOWN does to the robot."""
        self.move_base.cancel_goal("shutdown")
        if self.dock_action is not None:
            self.dock_action.cancel()
        self.undock_action.cancel()
        self.robot.stop()
        self.halted = True

    def scan(self, laser: LaserParams | None = None) -> LaserScan:
        """A scan from the true pose; ``laser`` overrides the configured laser (amcl casts only its beams)."""
        laser = laser or self.config.laser
        scan = cast_scan(self.field, self.robot.pose, laser, self.rng)
        if self.world is not None:
            scan = self.world.add_to_scan(scan, self.robot.pose, self.clock.now, laser.noise, self.rng)
        return scan

    def _collides(self, x: float, y: float, radius: float) -> bool:
        """The map's obstacles and, with a world, its objects and obstacles where they are now."""
        if self.field.collides(x, y, radius):
            return True
        return self.world is not None and self.world.collides(x, y, radius, self.clock.now)

    def _collides_static(self, x: float, y: float, radius: float) -> bool:
        """The map's obstacles and the world's things that stand still: where a walker cannot step."""
        if self.field.collides(x, y, radius):
            return True
        return self.world is not None and self.world.collides_static(x, y, radius)

    def _count_collision(self, x: float, y: float, by: str, what: str) -> None:
        """Count a new contact once (until the robot is clear again) and record where it happened."""
        if self.in_contact:
            return
        self.collisions += 1
        self.collision_points.append((x, y))
        self.events.emit("collision", x=round(x, 3), y=round(y, 3), by=by, obstacle=what)
        self.in_contact = True

    def pose_estimate(self) -> Pose2D:
        """The pose navigation drives on: the true pose (``exact``) or the localizer's estimate."""
        return self.robot.pose if self.localizer is None else self.localizer.estimate

    # -- stepping -----------------------------------------------------------------------------------
    def _command(self, pose: Pose2D, dt: float) -> tuple[float, float]:
        if self.halted:
            return 0.0, 0.0
        if self.dock_action is not None and self.dock_action.active:
            return self.dock_action.control(pose, dt, self.in_contact)
        if self.undock_action.active:
            return self.undock_action.control(pose, dt, self.in_contact)
        if self.teleop is not None and not self.move_base.active:
            return self.teleop
        return self.move_base.control(pose if self.localizer is None else self.localizer.estimate, dt)

    def _deliver_action_results(self) -> None:
        for action in (self.dock_action, self.undock_action):
            if action is None:
                continue
            result = action.take_result()
            if result is None:
                continue
            callback, status, text = result
            self.events.emit("action_result", action=type(action).__name__, status=status.value, text=text)
            if callback is not None:
                self.clock.call_later(0.0, lambda cb=callback, s=status, t=text: cb(s, t))

    def step(self) -> None:
        dt = self.config.dt
        robot = self.robot
        v, w = self._command(robot.pose, dt)
        self.clock.tick()  # what happens from here on happens at the end of the step
        if self.robot_battery.is_empty:
            v = w = 0.0  # the motors have no power left
        x0, y0, yaw0 = robot.x, robot.y, robot.yaw
        x, y, yaw, nv, nw = robot.propose(v, w, dt)
        if (x != x0 or y != y0) and self._collides(x, y, robot.params.radius):
            hit = self.world.colliding(x, y, robot.params.radius, self.clock.now) if self.world is not None else []
            self._count_collision(x0, y0, "robot", hit[0] if hit else "map")
            robot.stop()
            x, y, nv = x0, y0, 0.0
            robot.accept(x, y, yaw, 0.0, nw)
        else:
            if self.in_contact and not self._collides(x, y, robot.params.radius + CONTACT_RELEASE):
                self.in_contact = False
            robot.accept(x, y, yaw, nv, nw)
        if self.crowd is not None and self.world is not None:
            self.crowd.step(self.clock.now, dt, robot.pose, robot.params.radius)
            # A walker that moved into the robot (a blind one, or the robot drove under its step) is a contact too.
            overlap = self.world.moving_overlap(robot.x, robot.y, robot.params.radius, self.clock.now)
            if overlap is not None:
                self._count_collision(robot.x, robot.y, "obstacle", overlap)
        ds = math.hypot(x - x0, y - y0)
        self.distance += ds
        self.odom.update(math.copysign(ds, nv), wrap_angle(yaw - yaw0))
        if self.localizer is not None:
            self.localizer.step(self.odom.pose, robot.pose)
        self._update_dock_contact()
        moving = abs(nv) > 1e-3 or abs(nw) > 1e-3
        self.robot_battery.update(dt, moving)
        self.laptop_battery.update(dt)
        self._deliver_action_results()
        self.clock.fire_due()
        if self.config.record_every and self.clock.steps % self.config.record_every == 0:
            self.trajectory.append((self.clock.now, robot.x, robot.y, robot.yaw))

    def _update_dock_contact(self) -> None:
        if self.dock_action is None or self.station is None:
            return
        target = self.station.docked_pose(self.robot.params.radius)
        on_dock = (self.dock_action.docked
                   and math.hypot(self.robot.x - target.x, self.robot.y - target.y) < 0.05)
        if on_dock != self.docked:
            self.docked = on_dock
            self.robot_battery.set_docked(on_dock)
            if not on_dock:
                self.dock_action.docked = False

    def odometry_in_map(self) -> Pose2D:
        """Where wheel odometry alone puts the robot, in the map frame (odom starts at the start pose)."""
        o, s = self.odom.pose, self.start
        c, n = math.cos(s.yaw), math.sin(s.yaw)
        return Pose2D(s.x + c * o.x - n * o.y, s.y + n * o.x + c * o.y, wrap_angle(s.yaw + o.yaw))

    def odometry_drift(self) -> float:
        """Distance between the odometry estimate and the true pose: what amcl has to correct."""
        return self.odometry_in_map().distance_to(self.robot.pose)

    def report(self) -> RobotReport:
        """Distance, collisions, odometry drift and the localizer's error, for the run's summary."""
        loc = self.localizer
        return RobotReport(
            distance=self.distance, odometry_drift=self.odometry_drift(), collisions=self.collisions,
            localization=self.config.localization,
            localization_error_mean=loc.errors.mean if loc is not None else 0.0,
            localization_error_max=loc.errors.max if loc is not None else 0.0,
            localization_updates=loc.updates if loc is not None else 0)

    def close(self) -> None:
        """Nothing to release: the simulator holds no connections (a live robot's ``close`` leaves its network)."""

    def run_for(self, seconds: float) -> None:
        """Step until ``seconds`` of simulation time have passed (for tests and tools)."""
        end = self.clock.steps + round(seconds / self.config.dt)
        while self.clock.steps < end:
            self.step()
