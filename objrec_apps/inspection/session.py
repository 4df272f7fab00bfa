"""One inspection: the mission on a map and a world, the simulated robot with its camera, and the report.

:func:`open_inspection` reads and checks every file (errors name the file and the field, as
:class:`InspectionError`); :class:`Inspection` builds the patrol from the mission through the patrol's
task API, runs it, and writes the report, the picture and the photos. The world the robot drives in may
differ from the world file (``remove``, ``shift``): the report then says what is absent or moved.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2

from navigation.camera import CameraParams, RGBDCamera
from navigation.docking import DockingStation
from navigation.geometry import Pose2D
from navigation.laser import LaserParams
from navigation.maps import MapError, OccupancyMap, load_map
from navigation.nav_params import NavParams, apply_to_simulation, configure_simulation
from navigation.patrol import PatrolMachine
from navigation.runner import Summary, run_patrol
from navigation.simulation import SimConfig, Simulation, StartPoseError
from navigation.world import World, WorldError, load_world
from strictio import OutputError, write_atomically

from .mission import Mission, MissionError, load_mission
from .picture import draw_inspection
from .report import InspectionReport

log = logging.getLogger(__name__)

#: The laser as move_base's local costmap reads it (see Inspection).
COSTMAP_LASER = LaserParams(beams=160, range_max=3.0)


class InspectionError(ValueError):
    """Files or options an inspection cannot use; one line naming the file and the field."""


def changed_world(world: World, remove: Sequence[str] = (), shift: Sequence[tuple[str, float, float]] = ()
                  ) -> tuple[World, list[str]]:
    """The world the robot meets: the world file with objects removed or shifted, and what was changed."""
    changes = []
    try:
        for name in remove:
            world = world.without(name)
            changes.append(f"{name} removed")
        for name, dx, dy in shift:
            world = world.moved(name, dx, dy)
            changes.append(f"{name} shifted by ({dx:g}, {dy:g}) m")
    except KeyError as exc:
        raise InspectionError(str(exc.args[0])) from None
    return world, changes


def _start_refused(exc: StartPoseError, pose: Pose2D, occ_map: OccupancyMap, world: World, config: SimConfig,
                   map_path: Path | str, world_path: Path | str) -> str:
    """The simulator's refusal of a start pose, naming the file that puts something there: the world file
    and its objects on the pose, else the map (off it, or inside one of its obstacles), which the simulator's
    message names already."""
    inside = world.colliding(pose.x, pose.y, config.robot.radius)
    if inside:
        names = ", ".join(repr(name) for name in inside)
        return f"{world_path or world.source}: {names} {'stands' if len(inside) == 1 else 'stand'} on the start " \
               f"pose ({pose.x:.3f}, {pose.y:.3f}): the robot (radius {config.robot.radius:g} m) cannot start there"
    text = str(exc)
    return text if occ_map.source is not None else f"{map_path or 'the map'}: {text.removeprefix('the map: ')}"


class Inspection:
    """A mission ready to run; ``report`` fills up visit by visit as the patrol goes."""

    def __init__(self, mission: Mission, occ_map: OccupancyMap, reference: World, *, map_path: Path | str = "",
                 world_path: Path | str = "", simulated: World | None = None, changes: Sequence[str] = (),
                 config: SimConfig | None = None, start: Pose2D | None = None, laps: int | None = None,
                 camera: CameraParams | None = None, out_dir: Path | None = None, nav: NavParams | None = None
                 ) -> None:
        objects = {o.name for o in reference.objects}
        for row in mission.expected:
            for e in row:
                if e.name not in objects:
                    raise InspectionError(f"{mission.path}: {e.where}: no object {e.name!r} in the world file "
                                          f"{world_path or reference.source} (objects: {', '.join(sorted(objects))})")
        self.mission, self.map, self.reference = mission, occ_map, reference
        self.world = simulated if simulated is not None else reference
        self.out_dir = out_dir
        goals = list(mission.poses.goals)
        station_pose = mission.poses.station
        station = DockingStation.in_front_of(station_pose) if station_pose else None
        config = config or SimConfig()
        if nav is not None:  # inflation, cost shape, keepout cells and controller settings, before the planner is built
            config = configure_simulation(config, nav, occ_map)
        try:
            self.sim = Simulation(occ_map, self.sim_start(start, station_pose, goals, mission), config,
                                  station=station, world=self.world)
        except StartPoseError as exc:
            raise InspectionError(_start_refused(exc, self.sim_start(start, station_pose, goals, mission), occ_map,
                                                 self.world, config, map_path, world_path)) from None
        # move_base's local costmap reads the laser, which sees the world's obstacles: drive round them.
        # It marks within 2.5 m and clears within 3 m, so a scan of that reach with a beam every 0.36 degrees
        # (1.6 cm apart at 2.5 m, a third of a map cell) tells it as much as the full scan, for a fraction of it.
        self.sim.move_base.scan_source = lambda: self.sim.scan(COSTMAP_LASER)
        #: The keepout and speed zones' picture layer (None: no masks); the speed zones now cap move_base.
        self.zones = apply_to_simulation(self.sim, nav) if nav is not None else None
        self.camera = RGBDCamera(camera, random_seed=config.seed)
        self.machine = PatrolMachine(
            self.sim, goals, station_pose, max_laps=laps or mission.laps, tasks=mission.tasks,
            first_pose=mission.first_pose, stop_on_failure=mission.stop_on_failure, camera=self.capture,
            output_dir=out_dir / "photos" if out_dir is not None else None)
        self.report = InspectionReport(mission, reference, {
            "mission": str(mission.path), "map": str(map_path), "world": str(world_path or reference.source or ""),
            "changes": list(changes)})
        self.machine.visit_listeners.append(self.report.add_visit)

    @staticmethod
    def sim_start(start: Pose2D | None, station_pose: Pose2D | None, goals: list[Pose2D], mission: Mission) -> Pose2D:
        """Where the robot starts: ``--start``, else the docking station's pose, else the mission's first pose."""
        return start or station_pose or goals[mission.first_pose]

    def capture(self) -> Any:
        """A frame of the robot's camera now, from where the robot really is."""
        return self.camera.render(self.sim.world, self.map, self.sim.robot.pose, self.sim.clock.now)

    def run(self, time_limit: float | None = None, realtime: bool = False, handle_sigint: bool = True) -> Summary:
        summary = run_patrol(self.machine, time_limit=time_limit, realtime=realtime, handle_sigint=handle_sigint)
        self.machine.runner.end_visit()  # a run cut off before SHUTDOWN still reports its last visit
        return summary

    def picture(self, summary: Summary | None = None) -> Any:
        caption = ""
        if summary is not None:
            counts: dict[str, int] = {}
            for _, v in self.report.objects.values():
                counts[v.status] = counts.get(v.status, 0) + 1
            caption = (f"{self.mission.path.name}: {summary.outcome}  visits {len(self.report.visits)}  "
                       + "  ".join(f"{k.replace('_', ' ')} {n}" for k, n in sorted(counts.items())))
        return draw_inspection(self.map, self.reference, self.sim.world, self.report, self.sim.trajectory,
                               self.machine.goals, self.sim.collision_points, caption, zones=self.zones)

    def write(self, summary: Summary) -> list[Path]:
        """report.json, report.md and map.png in the output folder."""
        if self.out_dir is None:
            raise InspectionError("no output folder")
        ok, png = cv2.imencode(".png", self.picture(summary))
        try:
            if not ok:
                raise OutputError(str(self.out_dir / "map.png"), "OpenCV cannot encode the picture")
            write_atomically(self.out_dir / "map.png", png.tobytes())
            written = self.report.write(self.out_dir, summary.as_dict(), "map.png")
        except OutputError as exc:
            raise InspectionError(str(exc)) from None
        return [*written, self.out_dir / "map.png"]


def open_inspection(mission_path: str | Path, map_path: str | Path, world_path: str | Path, *,
                    remove: Sequence[str] = (), shift: Sequence[tuple[str, float, float]] = (), **options: Any
                    ) -> Inspection:
    """Read the mission, map and world files and build the inspection (options as for :class:`Inspection`)."""
    try:
        mission = load_mission(mission_path)
        occ_map = load_map(map_path)
        reference = load_world(world_path)
    except (MissionError, MapError, WorldError) as exc:
        raise InspectionError(str(exc)) from None
    simulated, changes = changed_world(reference, remove, shift)
    return Inspection(mission, occ_map, reference, map_path=map_path, world_path=world_path, simulated=simulated,
                      changes=changes, **options)
