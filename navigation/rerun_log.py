"""Rerun recordings of a patrol (``objrec-patrol --rerun out.rrd|spawn``, the ``viz`` extra).

Everything is on one ``sim_time`` timeline (simulated seconds, a duration) and in the map frame, metres:

- ``world/map``: the occupancy grid as a ``rr.GridMap`` (RViz map colours), placed at the map's origin;
- ``world/goals``, ``world/station``, ``world/dock``: the patrol's goal poses (labelled ``POSE_i`` as the
  machine names them), the station pose and the dock, as arrows;
- ``world/robot``: the robot's pose (``rr.Transform3D``) every ``pose_period``, carrying its body, its
  heading and ``world/robot/scan``, a laser scan (points in the robot's frame) every ``scan_period``;
- ``world/path/NNNN``: the path driven, as line strips of up to ``path_block`` points (a new strip starts
  when one is full, so each log stays small however long the patrol);
- ``world/goal`` and ``world/plan``: the goal being driven to and its global plan, cleared when it ends;
- ``world/collisions``: where the robot bumped into something;
- ``log/state``: the state machine's changes, and ``log/events``: every other event, as text log entries;
- ``battery/robot``, ``battery/laptop``: the battery percentages.

The hooks are the simulation's own: the event bus (every event, as it is emitted) and a periodic timer on
the simulation clock (poses, scans, batteries). Nothing of the run changes: the recorder's scans draw their
noise from a generator of their own, not from the simulation's. rerun-sdk is imported only when a
recording is opened, so this module loads without the extra. The module imports nothing of objrec_*.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from rerunio import VIEWER_PORT, Recorder, import_rerun, open_stream
from strictio import OutputError

from .events import Event
from .geometry import Pose2D
from .laser import cast_scan
from .simulation import Simulation

log = logging.getLogger(__name__)

# Heights above the map plane, so that lines and arrows are drawn over the grid, not into it.
Z_PATH, Z_PLAN, Z_MARK, Z_BODY = 0.02, 0.03, 0.05, 0.10
ARROW_LENGTH = 0.4
COLOURS = {"path": (40, 110, 255), "plan": (0, 200, 0), "goal": (255, 160, 0), "goals": (255, 215, 0),
           "station": (160, 0, 200), "robot": (60, 60, 60), "scan": (230, 30, 30), "collision": (255, 0, 0)}
WARNING_EVENTS = {"collision", "recovery", "preempt_requested"}



def patrol_blueprint() -> Any:
    """The map scene beside the state and event logs, the batteries below."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(rrb.Horizontal(
        rrb.Spatial3DView(origin="/world", name="map"),
        rrb.Vertical(rrb.TextLogView(origin="/log", name="states and events"),
                     rrb.TimeSeriesView(origin="/battery", name="batteries (%)")),
        column_shares=[3, 2]))


def _arrows(rr: Any, poses: Sequence[Pose2D], labels: Sequence[str], colour: tuple[int, int, int]) -> Any:
    return rr.Arrows3D(
        origins=[[p.x, p.y, Z_MARK] for p in poses],
        vectors=[[ARROW_LENGTH * math.cos(p.yaw), ARROW_LENGTH * math.sin(p.yaw), 0.0] for p in poses],
        labels=list(labels), colors=[colour] * len(poses))


def _check_periods(pose_period: float, scan_period: float) -> None:
    if not (pose_period > 0 and scan_period > 0):
        raise ValueError(f"periods must be positive, got pose {pose_period}, scan {scan_period}")


def _level(event: Event) -> str:
    """WARN for what a person watching the patrol should notice: bumps, failed goals, low batteries."""
    kind = event["type"]
    failed_goal = kind == "goal_result" and event.get("status") != "SUCCEEDED"
    low_battery = kind in ("robot_battery", "laptop_battery") and str(event.get("event")).endswith(("LOW", "CRITICAL"))
    return "WARN" if kind in WARNING_EVENTS or failed_goal or low_battery else "INFO"


def _event_text(event: Event) -> str:
    fields = ", ".join(f"{k}={v}" for k, v in event.items() if k not in ("t", "type"))
    return f"{event['type']}: {fields}" if fields else str(event["type"])


class PatrolRecorder(Recorder):
    """Logs a simulation to a Rerun recording from the moment it is made until :meth:`close`.

    Make it after the simulation and before the run; it hooks itself onto the event bus and the clock. A failed
    write is noticed every ``rerunio.CHECK_EVERY`` samples (``rerunio.Recorder``), ending the run with one line.
    """

    def __init__(self, recording: Any, sim: Simulation, goals: Sequence[Pose2D] = (),
                 station_pose: Pose2D | None = None, *, pose_period: float = 0.2, scan_period: float = 1.0,
                 path_spacing: float = 0.05, path_block: int = 256) -> None:
        _check_periods(pose_period, scan_period)
        super().__init__(recording)
        self.sim = sim
        self.path_spacing = path_spacing
        self.path_block = max(2, path_block)
        self.path_strips = 0  # strips started so far: world/path/0000 ...
        self._path: list[tuple[float, float]] = []
        self._scan_rng = np.random.default_rng(sim.config.seed)  # never the simulation's own generator
        self._log_static(goals, station_pose)
        self._set_time(sim.clock.now)
        self._sample()
        self._scan()
        self._unsubscribe: Callable[[], None] | None = sim.events.subscribe(self._on_event)
        self._timers = [sim.clock.every(pose_period, self._timed(self._sample)),
                        sim.clock.every(scan_period, self._timed(self._scan))]

    # -- what does not change -------------------------------------------------------------------------
    def _log_static(self, goals: Sequence[Pose2D], station_pose: Pose2D | None) -> None:
        rr, rec, sim = self._rr, self.recording, self.sim
        occ = sim.map
        grid = np.ascontiguousarray(occ.data[::-1]).view(np.uint8)  # top row first; unknown (-1) is 255
        rec.log("world/map", rr.GridMap(
            data=grid.tobytes(),
            format=rr.components.ImageFormat(width=occ.width, height=occ.height, color_model="L",
                                             channel_datatype="U8"),
            cell_size=occ.resolution, translation=[occ.origin.x, occ.origin.y, 0.0],
            rotation_axis_angle=rr.RotationAxisAngle(axis=[0.0, 0.0, 1.0], radians=occ.origin.yaw),
            colormap=rr.components.Colormap.RvizMap), static=True)
        if goals:
            rec.log("world/goals", _arrows(rr, goals, [f"POSE_{i}" for i in range(len(goals))], COLOURS["goals"]),
                    static=True)
        if station_pose is not None:
            rec.log("world/station", _arrows(rr, [station_pose], ["station"], COLOURS["station"]), static=True)
        if sim.station is not None:
            rec.log("world/dock", _arrows(rr, [sim.station.pose], ["dock"], COLOURS["station"]), static=True)
        radius = sim.config.robot.radius
        rec.log("world/robot/body", rr.Cylinders3D(lengths=[Z_BODY], radii=[radius], centers=[[0, 0, Z_BODY / 2]],
                                                   colors=[COLOURS["robot"]]), static=True)
        rec.log("world/robot/heading", rr.Arrows3D(origins=[[0, 0, Z_BODY]], vectors=[[1.5 * radius, 0, 0]],
                                                   colors=[COLOURS["robot"]]), static=True)

    # -- what changes ---------------------------------------------------------------------------------
    def _set_time(self, seconds: float) -> None:
        self.set_time("sim_time", duration=float(seconds))

    def _timed(self, sample: Callable[[], None]) -> Callable[[], None]:
        def run() -> None:
            self._set_time(self.sim.clock.now)
            sample()
            self.step_logged()

        return run

    def _sample(self) -> None:
        """The pose, the path driven and the batteries, now."""
        rr, rec, sim = self._rr, self.recording, self.sim
        pose = sim.robot.pose
        rec.log("world/robot", rr.Transform3D(
            translation=[pose.x, pose.y, 0.0],
            rotation_axis_angle=rr.RotationAxisAngle(axis=[0.0, 0.0, 1.0], radians=pose.yaw)))
        rec.log("battery/robot", rr.Scalars(sim.robot_battery.percentage))
        rec.log("battery/laptop", rr.Scalars(sim.laptop_battery.percentage))
        path = self._path
        if path and math.hypot(pose.x - path[-1][0], pose.y - path[-1][1]) < self.path_spacing:
            return
        if not path or len(path) >= self.path_block:
            self._path = path = path[-1:]  # the new strip starts where the full one ended
            self.path_strips += 1
        path.append((pose.x, pose.y))
        if len(path) >= 2:
            rec.log(f"world/path/{self.path_strips - 1:04d}",
                    rr.LineStrips3D([[[x, y, Z_PATH] for x, y in path]], colors=[COLOURS["path"]]))

    def _scan(self) -> None:
        """A laser scan from the robot's pose, as points in the robot's frame (inf ranges left out)."""
        sim = self.sim
        scan = cast_scan(sim.field, sim.robot.pose, sim.config.laser, self._scan_rng)
        angles, ranges = scan.angles(), scan.ranges
        hit = np.isfinite(ranges)
        points = np.column_stack((ranges[hit] * np.cos(angles[hit]), ranges[hit] * np.sin(angles[hit]),
                                  np.full(int(hit.sum()), Z_BODY)))
        self.recording.log("world/robot/scan", self._rr.Points3D(points, colors=[COLOURS["scan"]]))

    def _on_event(self, event: Event) -> None:
        rr, rec, sim = self._rr, self.recording, self.sim
        self._set_time(event["t"])
        kind = event["type"]
        if kind in ("state_enter", "state_exit"):
            verb = "enter" if kind == "state_enter" else "exit"
            rec.log("log/state", rr.TextLog(f"{verb} {event['state']}", level="INFO" if verb == "enter" else "DEBUG"))
            return
        rec.log("log/events", rr.TextLog(_event_text(event), level=_level(event)))
        if kind == "goal_sent":
            goal = Pose2D(event["x"], event["y"], event["yaw"])
            rec.log("world/goal", _arrows(rr, [goal], [str(event.get("name") or event["goal_id"])], COLOURS["goal"]))
        elif kind == "plan":
            plan = sim.move_base.last_plan
            if event.get("ok") and plan is not None and len(plan.path) >= 2:
                rec.log("world/plan", rr.LineStrips3D([[[x, y, Z_PLAN] for x, y in plan.path]],
                                                      colors=[COLOURS["plan"]]))
            else:
                rec.log("world/plan", rr.Clear(recursive=False))
        elif kind == "goal_result":
            rec.log("world/goal", rr.Clear(recursive=False))
            rec.log("world/plan", rr.Clear(recursive=False))
        elif kind == "collision":
            rec.log("world/collisions", rr.Points3D([[x, y, Z_MARK] for x, y in sim.collision_points],
                                                    colors=[COLOURS["collision"]], radii=[0.05]))

    def _before_close(self) -> None:
        """Unhook from the simulation and log the final pose."""
        self._unhook()
        self._set_time(self.sim.clock.now)
        self._sample()

    def _unhook(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        for timer in self._timers:
            timer.cancel()

    def check_writing(self) -> None:
        """As the base, and a recording that failed stops listening to the simulation at once."""
        try:
            super().check_writing()
        except OutputError:
            self._unhook()
            raise


def open_patrol_rerun(target: str | os.PathLike[str], sim: Simulation, goals: Sequence[Pose2D] = (),
                      station_pose: Pose2D | None = None, *, port: int = VIEWER_PORT, **options: Any
                      ) -> PatrolRecorder:
    """A :class:`PatrolRecorder` logging ``sim`` to ``target`` (a ``.rrd`` path, or ``spawn``).

    Raises :class:`RerunUnavailable` (one line for the user) when rerun-sdk is missing, no viewer can be
    spawned or the file cannot be written. ``options`` go to :class:`PatrolRecorder` (periods, path strips).
    """
    _check_periods(options.get("pose_period", 0.2), options.get("scan_period", 1.0))
    import_rerun()
    stream = open_stream(target, "objrec-patrol", patrol_blueprint(), port)
    recorder = PatrolRecorder(stream, sim, goals, station_pose, **options)
    recorder.target = str(target)
    return recorder
