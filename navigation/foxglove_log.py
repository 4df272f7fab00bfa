"""A patrol served live to Foxglove (``objrec-patrol --foxglove [HOST:]PORT``, the ``viz`` extra).

Channels (frames ``map`` and ``base_link``; times are the run's start on the wall clock plus simulated seconds,
so a run in ``--realtime`` is stamped with the wall clock and a run flat out runs ahead of it):

- ``/map``: the occupancy grid (``foxglove.Grid``): an ``occupancy`` field (int8, map_server's -1 unknown,
  0..100) and ``red``/``green``/``blue``/``alpha`` fields in RViz's map colours; sent again to every viewer
  that subscribes (a live WebSocket has no latching);
- ``/tf``: ``map`` to ``base_link``, the robot's true pose (``foxglove.FrameTransforms``), and
  ``/robot/pose`` (``foxglove.PoseInFrame``), every ``pose_period`` simulated seconds;
- ``/robot/path``: the path driven (``foxglove.PosesInFrame``), the last :data:`PATH_POINTS` points;
- ``/robot/scan``: a laser scan in ``base_link`` (``foxglove.LaserScan``) every ``scan_period``;
- ``/patrol/goals``: the goal poses (``foxglove.PosesInFrame``), and ``/patrol/labels``: their names
  (``POSE_i``), the station and the dock as texts (``foxglove.SceneUpdate``), both resent to a new viewer;
- ``/patrol/goal`` and ``/patrol/plan``: the goal being driven to and its global plan (empty when it ends);
- ``/patrol/state``: JSON ``{"t", "states", "entering"}``: the machine's active states, at every change
  (resent to a new viewer); ``/patrol/events``: every other event as a ``foxglove.Log`` (warning level for
  bumps, failed goals, low batteries); ``/patrol/battery``: JSON ``{"t", "robot", "laptop"}`` percentages.

The hooks are the simulation's own, as for the Rerun recording (:mod:`navigation.rerun_log`): the event bus,
timers on the simulation clock and the machine's state listeners. The scans draw their noise from a generator
of their own, so the run is the same with or without a viewer. Nothing is built for a channel no viewer
subscribes to, and a slow viewer loses messages rather than slowing the patrol
(:mod:`foxgloveio.server`); a scan is cast at most :data:`SCANS_PER_SECOND` and the path sent at
most :data:`PATHS_PER_SECOND` times a wall-clock second, since a run flat out would otherwise spend its time
on messages nobody can look at that fast.
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from foxgloveio.server import Address, LiveServer, timestamp

from .events import Event
from .geometry import Pose2D
from .laser import cast_scan
from .maps import OccupancyMap
from .patrol import PatrolMachine
from .rerun_log import _event_text, _level
from .robot_interface import PatrolRobot
from .simulation import Simulation

log = logging.getLogger(__name__)

MAP_FRAME, ROBOT_FRAME = "map", "base_link"
#: Points of the driven path a viewer gets (the newest): one message stays small however long the patrol.
PATH_POINTS = 2000
#: Scans cast for a viewer per wall-clock second at most.
SCANS_PER_SECOND = 10.0
#: Driven paths (up to PATH_POINTS poses each) sent per wall-clock second at most.
PATHS_PER_SECOND = 5.0
STATE_SCHEMA = {"title": "objrec.PatrolState", "type": "object",
                "properties": {"t": {"type": "number", "description": "simulated seconds"},
                               "states": {"type": "array", "items": {"type": "string"}},
                               "entering": {"type": "string"}}}
BATTERY_SCHEMA = {"title": "objrec.Batteries", "type": "object",
                  "properties": {"t": {"type": "number"}, "robot": {"type": "number"},
                                 "laptop": {"type": "number"}}}


def yaw_quaternion(yaw: float) -> Any:
    from foxglove.messages import Quaternion

    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def pose_message(pose: Pose2D) -> Any:
    from foxglove.messages import Pose, Vector3

    return Pose(position=Vector3(x=pose.x, y=pose.y, z=0.0), orientation=yaw_quaternion(pose.yaw))


def map_colours(occupancy: np.ndarray) -> np.ndarray:
    """RViz's map colours (RGBA) of map_server values: free light grey, occupied black, unknown blue-grey,
    and in between a grey from light to dark."""
    values = occupancy.astype(np.int16)
    level = np.clip(values, 0, 100)
    grey = (254 - level * 254 // 100).astype(np.uint8)
    rgba = np.stack([grey, grey, grey, np.full_like(grey, 255)], axis=-1)
    rgba[values < 0] = (112, 137, 134, 255)
    return rgba


def grid_message(occ: OccupancyMap, stamp: Any) -> Any:
    """The map as a ``foxglove.Grid``: row 0 at the map's origin (map_server's order), 5 bytes a cell."""
    from foxglove.messages import Grid, PackedElementField, PackedElementFieldNumericType, Pose, Vector2, Vector3

    cells = np.empty(occ.data.shape, dtype=[("occupancy", "i1"), ("red", "u1"), ("green", "u1"), ("blue", "u1"),
                                            ("alpha", "u1")])
    cells["occupancy"] = occ.data
    rgba = map_colours(occ.data)
    for i, name in enumerate(("red", "green", "blue", "alpha")):
        cells[name] = rgba[..., i]
    u8 = PackedElementFieldNumericType.Uint8
    fields = [PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Int8)]
    fields += [PackedElementField(name=n, offset=1 + i, type=u8)
               for i, n in enumerate(("red", "green", "blue", "alpha"))]
    origin = Pose(position=Vector3(x=occ.origin.x, y=occ.origin.y, z=0.0), orientation=yaw_quaternion(occ.origin.yaw))
    return Grid(timestamp=stamp, frame_id=MAP_FRAME, pose=origin, column_count=int(occ.width),
                cell_size=Vector2(x=occ.resolution, y=occ.resolution), row_stride=5 * int(occ.width), cell_stride=5,
                fields=fields, data=cells.tobytes())


class PatrolView:
    """Serves a patrol live from the moment it is made until :meth:`close` (which stops the server).

    Make it after the machine and before the run; it hooks itself onto the robot's event log and clock and the
    machine's state listeners. The robot is the simulator or a live one (``--robot``): of a live robot it
    serves the pose the robot reports (``pose_estimate``) and no scan (the simulator's scans are cast on the
    map, a live robot's own laser is on its own topics).
    """

    def __init__(self, server: LiveServer, sim: PatrolRobot, occ_map: OccupancyMap,
                 machine: PatrolMachine | None = None, goals: Sequence[Pose2D] = (),
                 station_pose: Pose2D | None = None, *, pose_period: float = 0.2, scan_period: float = 1.0) -> None:
        from foxglove.channels import (
            FrameTransformsChannel,
            GridChannel,
            LaserScanChannel,
            LogChannel,
            PoseInFrameChannel,
            PosesInFrameChannel,
            SceneUpdateChannel,
        )

        if not (pose_period > 0 and scan_period > 0):
            raise ValueError(f"periods must be positive, got pose {pose_period}, scan {scan_period}")
        self.server, self.sim, self.machine, self.occ_map = server, sim, machine, occ_map
        self.simulated = sim if isinstance(sim, Simulation) else None
        self._epoch_ns = time.time_ns() - round(sim.clock.now * 1e9)
        ch = server.channel
        self.map = ch(GridChannel, "/map")
        self.tf = ch(FrameTransformsChannel, "/tf")
        self.pose = ch(PoseInFrameChannel, "/robot/pose")
        self.path = ch(PosesInFrameChannel, "/robot/path")
        self.scan = ch(LaserScanChannel, "/robot/scan")
        self.goals = ch(PosesInFrameChannel, "/patrol/goals")
        self.labels = ch(SceneUpdateChannel, "/patrol/labels")
        self.goal = ch(PoseInFrameChannel, "/patrol/goal")
        self.plan = ch(PosesInFrameChannel, "/patrol/plan")
        self.events = ch(LogChannel, "/patrol/events")
        self.state = server.json_channel("/patrol/state", STATE_SCHEMA)
        self.battery = server.json_channel("/patrol/battery", BATTERY_SCHEMA)
        self.samples = 0
        self._path: deque[Pose2D] = deque(maxlen=PATH_POINTS)
        seed = self.simulated.config.seed if self.simulated is not None else None
        self._scan_rng = np.random.default_rng(seed)  # never the simulation's own generator
        self._next_scan = self._next_path = 0.0  # wall clock (monotonic) of the next scan, path a viewer may get
        self._closed = False
        self._states: list[str] | None = None
        self._log_static(goals, station_pose)
        self.sample()
        self._unsubscribe: Callable[[], None] | None = sim.events.subscribe(self._on_event)
        self._timers = [sim.clock.every(pose_period, self.sample)]
        if self.simulated is not None:
            self._timers.append(sim.clock.every(scan_period, self._scan))
        if machine is not None:
            machine.state_listeners.append(self._on_state)
            self._on_state(machine)

    # -- time ---------------------------------------------------------------------------------------------
    def now_ns(self, seconds: float | None = None) -> int:
        return self._epoch_ns + round((self.sim.clock.now if seconds is None else seconds) * 1e9)

    # -- what does not change -------------------------------------------------------------------------
    def _log_static(self, goals: Sequence[Pose2D], station_pose: Pose2D | None) -> None:
        from foxglove.messages import (
            Color,
            Pose,
            PosesInFrame,
            SceneEntity,
            SceneUpdate,
            TextPrimitive,
            Vector3,
        )

        when = self.now_ns()
        stamp = timestamp(when)
        self.server.latch(self.map, grid_message(self.occ_map, stamp), when)
        self.server.latch(self.goals, PosesInFrame(timestamp=stamp, frame_id=MAP_FRAME,
                                                   poses=[pose_message(g) for g in goals]), when)
        named = [(f"POSE_{i}", g) for i, g in enumerate(goals)]
        if station_pose is not None:
            named.append(("station", station_pose))
        if self.simulated is not None and self.simulated.station is not None:
            named.append(("dock", self.simulated.station.pose))
        white = Color(r=1.0, g=1.0, b=1.0, a=1.0)
        texts = [TextPrimitive(pose=Pose(position=Vector3(x=p.x, y=p.y, z=0.3), orientation=yaw_quaternion(0.0)),
                               billboard=True, font_size=14.0, scale_invariant=True, color=white, text=name)
                 for name, p in named]
        self.server.latch(self.labels, SceneUpdate(entities=[
            SceneEntity(timestamp=stamp, frame_id=MAP_FRAME, id="patrol/labels", texts=texts)]), when)

    # -- what changes ---------------------------------------------------------------------------------
    def robot_pose(self) -> Pose2D:
        """Where the robot is: the simulator's true pose, or what a live robot reports."""
        return self.simulated.robot.pose if self.simulated is not None else self.sim.pose_estimate()

    def sample(self) -> None:
        """The pose (as a transform and a pose), the path driven and the batteries, now."""
        from foxglove.messages import FrameTransform, FrameTransforms, PoseInFrame, PosesInFrame, Vector3

        sim, wanted = self.sim, self.server.wanted
        pose = self.robot_pose()
        when = self.now_ns()
        stamp = timestamp(when)
        if not self._path or self._path[-1].distance_to(pose) >= 0.05:
            self._path.append(pose)
        if wanted(self.tf):
            self.tf.log(FrameTransforms(transforms=[FrameTransform(
                timestamp=stamp, parent_frame_id=MAP_FRAME, child_frame_id=ROBOT_FRAME,
                translation=Vector3(x=pose.x, y=pose.y, z=0.0), rotation=yaw_quaternion(pose.yaw))]), log_time=when)
        if wanted(self.pose):
            self.pose.log(PoseInFrame(timestamp=stamp, frame_id=MAP_FRAME, pose=pose_message(pose)), log_time=when)
        if wanted(self.path) and (clock := time.monotonic()) >= self._next_path:
            self._next_path = clock + 1.0 / PATHS_PER_SECOND
            self.path.log(PosesInFrame(timestamp=stamp, frame_id=MAP_FRAME,
                                       poses=[pose_message(p) for p in self._path]), log_time=when)
        if wanted(self.battery):
            self.battery.log({"t": sim.clock.now, "robot": sim.robot_battery.percentage,
                              "laptop": sim.laptop_battery.percentage}, log_time=when)
        self.samples += 1

    def _scan(self) -> None:
        """A laser scan from the robot's pose, in the robot's frame (at most SCANS_PER_SECOND a wall second)."""
        from foxglove.messages import LaserScan, Pose, Quaternion, Vector3

        now = time.monotonic()
        sim = self.simulated
        if sim is None or not self.server.wanted(self.scan) or now < self._next_scan:
            return
        self._next_scan = now + 1.0 / SCANS_PER_SECOND
        scan = cast_scan(sim.field, sim.robot.pose, sim.config.laser, self._scan_rng)
        angles = scan.angles()
        when = self.now_ns()
        self.scan.log(LaserScan(
            timestamp=timestamp(when), frame_id=ROBOT_FRAME,
            pose=Pose(position=Vector3(x=0.0, y=0.0, z=0.1), orientation=Quaternion(w=1.0)),
            start_angle=float(angles[0]), end_angle=float(angles[-1]),
            ranges=[float(r) for r in scan.ranges]), log_time=when)

    def _on_state(self, machine: PatrolMachine) -> None:
        states = list(machine.active_states())
        if states == self._states:  # the machine reports leaving and entering; a viewer needs the change only
            return
        self._states = states
        self.server.latch(self.state, {"t": self.sim.clock.now, "states": states, "entering": machine.entering},
                          self.now_ns())

    def _on_event(self, event: Event) -> None:
        from foxglove.messages import Log, LogLevel, PoseInFrame, PosesInFrame

        when = self.now_ns(float(event["t"]))
        stamp = timestamp(when)
        kind = event["type"]
        if kind in ("state_enter", "state_exit"):
            return  # the state channel says it
        if self.server.wanted(self.events):
            level = LogLevel.Warning if _level(event) == "WARN" else LogLevel.Info
            self.events.log(Log(timestamp=stamp, level=level, message=_event_text(event), name="patrol"),
                            log_time=when)
        if kind == "goal_sent":
            goal = Pose2D(event["x"], event["y"], event["yaw"])
            self.goal.log(PoseInFrame(timestamp=stamp, frame_id=MAP_FRAME, pose=pose_message(goal)), log_time=when)
        elif kind == "plan":
            plan = getattr(self.sim.move_base, "last_plan", None)
            path = plan.path if event.get("ok") and plan is not None else []
            poses = [pose_message(Pose2D(float(x), float(y), 0.0)) for x, y in path]
            self.plan.log(PosesInFrame(timestamp=stamp, frame_id=MAP_FRAME, poses=poses), log_time=when)
        elif kind == "goal_result":
            self.plan.log(PosesInFrame(timestamp=stamp, frame_id=MAP_FRAME, poses=[]), log_time=when)

    # -- the end --------------------------------------------------------------------------------------
    def close(self) -> None:
        """Unhook from the simulation, send the final pose and stop the server; closing again does nothing."""
        if self._closed:
            return
        self._closed = True
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        for timer in self._timers:
            timer.cancel()
        if self.machine is not None and self._on_state in self.machine.state_listeners:
            self.machine.state_listeners.remove(self._on_state)
        try:
            self.sample()
        finally:
            self.server.close()


def open_patrol_view(address: Address, sim: PatrolRobot, occ_map: OccupancyMap, machine: PatrolMachine | None = None,
                     goals: Sequence[Pose2D] = (), station_pose: Pose2D | None = None, *,
                     name: str = "objrec-patrol", **options: Any) -> PatrolView:
    """A :class:`PatrolView` on a new server at ``address``; FoxgloveUnavailable (one line) when foxglove-sdk
    is missing or the address cannot be listened on. ``options`` go to the view (periods)."""
    server = LiveServer(address, name)
    try:
        return PatrolView(server, sim, occ_map, machine, goals, station_pose, **options)
    except BaseException:
        server.close()
        raise
