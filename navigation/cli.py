"""``objrec-patrol POSES_FILE --map MAP_YAML``: run the inspection patrol in the built-in simulator, or on a live
robot named by ``--robot`` (a plug-in of :mod:`navigation.robots`, e.g. ``ros1``).

Results (the summary) go to stdout, diagnostics to stderr. A map or pose file that cannot be used, an
option's value out of its declared range, or an output that cannot be written gives one error line naming
the file (or option) and why, and exit code 2. Ctrl-C or SIGTERM, also during start-up, preempts the patrol:
it ends in SHUTDOWN with its summary and events written, exit code 0; a second one gives up (130).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from foxgloveio.server import FoxgloveUnavailable, add_foxglove_argument
from rerunio import RerunUnavailable
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, Number, check_limit_settings, fields
from strictio.output_paths import RunFiles
from strictio.shown import printable
from strictio.signals import StopSignals

from .battery import LaptopBatteryParams, RobotBatteryParams, kobuki_percent, kobuki_voltage
from .diagram import write_diagram
from .docking import DockingStation
from .foxglove_log import PatrolView, open_patrol_view
from .geometry import Pose2D
from .laptop_monitor import laptop_battery_monitor
from .lost_options import add_lost_robot_options, apply_lost_robot_options
from .maps import MapError, OccupancyMap, load_map, load_map_metadata
from .nav_params import (
    NavParams,
    add_nav_params_options,
    apply_to_simulation,
    configure_simulation,
    in_keepout,
    nav_params_from_args,
    nav_params_inputs,
)
from .patrol import PatrolMachine
from .poses import PoseFileError, load_poses
from .render import ANIMATED, STILL, LocalizationMarks, RunPicture, save_render
from .rerun_log import PatrolRecorder, open_patrol_rerun
from .robots import DEFAULT_ROBOT, RobotError, RobotSetup, RobotUnavailable, open_robot, parse_robot_spec, robot_names
from .runner import MAX_STEPS, Summary, run_patrol
from .sim_options import add_simulation_options, simulation_config
from .simulation import SimConfig, Simulation, StartPoseError

log = logging.getLogger("navigation.cli")
PROG = "objrec-patrol"


# The command-line numbers, each declared once with its range (the inspection command shares these; the
# simulation's own are in navigation.sim_options).
COORDINATE = Number(-1e6, 1e6)  # metres in the map frame
YAW = Number(-math.tau, math.tau)  # radians
LAPS = Number(1, 100_000, whole=True)
TIME_LIMIT = Number(0, 1e7, above=True)  # simulated seconds
PERCENT = Number(0, 100)
HOURS = Number(0.01, 1000)
DOCK_DISTANCE = Number(0.1, 10)  # metres


def build_parser() -> argparse.ArgumentParser:
    p = CommandLineParser(
        prog=PROG,
        description="Patrol the goal poses of POSES_FILE on a ROS map in a built-in 2D simulator, with the "
                    "patrol state machine (battery monitors, docking, shutdown).")
    p.add_argument("poses", metavar="POSES_FILE", help="goal poses, one 'x, y, z, qx, qy, qz, qw' per line")
    p.add_argument("--map", required=True, metavar="MAP_YAML", help="ROS map_server YAML file")
    p.add_argument("--start", nargs=3, action=fields(COORDINATE, COORDINATE, YAW), metavar=("X", "Y", "YAW"),
                   help="start pose in the map frame, metres and radians (default: the station pose, else the "
                        "first goal)")
    stop = p.add_argument_group(
        "when to stop", f"By default when the machine ends by itself, or on Ctrl-C or SIGTERM; a run flat out "
        f"ends after {MAX_STEPS:,} steps in any case.")
    stop.add_argument("--laps", type=LAPS, metavar="N", help=f"end after N laps of the goals ({LAPS.describe()})")
    stop.add_argument("--time-limit", type=TIME_LIMIT, metavar="SECONDS",
                      help="preempt after this much simulated time")
    bat = p.add_argument_group("batteries (percentages in 0..100, hours in 0.01..1000)")
    bat.add_argument("--robot-battery", type=PERCENT, default=100.0, metavar="PERCENT",
                     help="robot battery at the start (default 100)")
    bat.add_argument("--robot-battery-low", type=PERCENT, metavar="PERCENT",
                     help=f"robot low threshold (default {kobuki_percent(14.0):.0f}, the Kobuki's 14.0 V)")
    bat.add_argument("--robot-runtime", type=HOURS, default=3.0, metavar="HOURS",
                     help="robot driving time on a full battery (default 3)")
    bat.add_argument("--robot-charge-time", type=HOURS, default=1.5, metavar="HOURS",
                     help="time on the dock from empty to full (default 1.5)")
    bat.add_argument("--laptop-battery", type=PERCENT, default=100.0, metavar="PERCENT",
                     help="laptop battery at the start (default 100)")
    bat.add_argument("--laptop-battery-low", type=PERCENT, default=20.0, metavar="PERCENT",
                     help="laptop low threshold (default 20)")
    bat.add_argument("--laptop-runtime", type=HOURS, default=2.5, metavar="HOURS",
                     help="laptop time on battery (default 2.5)")
    bat.add_argument("--laptop-plugged", action="store_true",
                     help="the laptop is on mains power: no laptop battery monitor (LAPTOP_BATTERY_MONITOR)")
    dock = p.add_argument_group("docking")
    dock.add_argument("--no-station", action="store_true", help="ignore the station pose in POSES_FILE")
    dock.add_argument("--dock-distance", type=DOCK_DISTANCE, default=1.0, metavar="METRES",
                      help=f"distance from the station pose to the dock ahead of it (default 1.0; "
                           f"{DOCK_DISTANCE.describe()})")
    dock.add_argument("--resume-after-charging", action="store_true",
                      help="undock and patrol on when charged, instead of shutting down")
    live = p.add_argument_group(
        "robot", "The simulator is the default. A live robot drives the same state machine: see docs/navigation.md, "
        "\"The patrol on a real robot (ROS 1)\".")
    live.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME[,KEY=VALUE...]",
                      help="the robot to patrol with: sim (default) or an installed one, e.g. "
                           "ros1,master=http://HOST:11311,kobuki=/mobile_base/sensors/core for a TurtleBot 2 "
                           f"(installed: {', '.join(robot_names())}); the options of a robot are in docs/navigation.md")
    add_simulation_options(p)
    add_nav_params_options(p)
    add_lost_robot_options(p)
    out = p.add_argument_group("output")
    out.add_argument("--events", metavar="FILE", help="write every event as JSON Lines")
    out.add_argument("--render", metavar="PATH",
                     help=f"picture of the run ({', '.join(STILL)}) or animation ({', '.join(ANIMATED)})")
    out.add_argument("--diagram", metavar="PATH",
                     help="Mermaid diagram of the machine, active states marked, kept up to date (.md: fenced)")
    out.add_argument("--rerun", metavar="FILE.rrd|spawn",
                     help="record the map, the robot's pose and path, scans, goals and state changes for the "
                          "Rerun viewer: a .rrd file, or spawn to open the viewer (needs objrec[viz])")
    add_foxglove_argument(out)
    out.add_argument("-v", "--verbose", action="count", default=0, help="more log output on stderr")
    return p


def _format_time(seconds: float) -> str:
    h, rem = divmod(round(seconds), 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}"


def format_summary(summary: Summary) -> str:
    reason = f" ({summary.preempt_reason})" if summary.preempt_reason else ""
    rows = [
        ("outcome", f"{summary.outcome}{reason}"),
        ("final state", ", ".join(summary.final_states) or "-"),
        ("time", f"{_format_time(summary.sim_time)} ({summary.sim_time:.1f} s) on the live robot")
        if summary.wall_clock else
        ("simulated time", f"{_format_time(summary.sim_time)} ({summary.sim_time:.1f} s) in "
                           f"{summary.wall_time:.2f} s wall ({summary.speedup:.0f}x real time)"),
        ("laps", str(summary.laps)),
        ("goals", f"{summary.goals_reached} reached, {summary.goals_aborted} aborted, "
                  f"{summary.goals_preempted} preempted"),
        ("distance", f"{summary.distance:.1f} m (odometry drifted {summary.odometry_drift:.2f} m)"),
        ("localization", _format_localization(summary)),
        ("collisions", str(summary.collisions)),
        ("robot battery", _percent(summary.robot_battery)),
        ("laptop battery", _percent(summary.laptop_battery)),
    ]
    return "\n".join(f"{k + ':':16s}{v}" for k, v in rows)


def _percent(value: float) -> str:
    """A battery level; a live robot's battery that was never heard of is unknown (NaN)."""
    return "unknown" if math.isnan(value) else f"{value:.1f} %"


def _format_localization(summary: Summary) -> str:
    if summary.wall_clock:
        return f"from {summary.localization}"  # a live robot: what its localizer publishes
    if summary.localization == "exact":
        return "exact (navigation sees the true pose)"
    updates = f", {summary.localization_updates} filter updates" if summary.localization == "amcl" else ""
    lost = (f"; lost {summary.localization_lost} time(s), relocalised {summary.localization_regained}"
            if summary.localization_lost else "")
    return (f"{summary.localization}: estimate off by {summary.localization_error_mean:.3f} m on average, "
            f"{summary.localization_error_max:.3f} m at most{updates}{lost}")


def _config(args: argparse.Namespace, nav: NavParams, occ_map: OccupancyMap) -> SimConfig:
    """The simulation's settings: its options, the batteries, and the navigation parameters (``nav``: the file under
    the command line's options), the keepout mask read once for the planner the simulation builds."""
    base = SimConfig()
    robot_low = args.robot_battery_low
    robot_params = RobotBatteryParams(
        runtime_h=args.robot_runtime, charge_time_h=args.robot_charge_time,
        low_voltage=kobuki_voltage(robot_low) if robot_low is not None else base.robot_battery.low_voltage)
    config = replace(
        simulation_config(args, base), robot_battery=robot_params, robot_battery_percent=args.robot_battery,
        laptop_battery=LaptopBatteryParams(runtime_h=args.laptop_runtime, low_percent=args.laptop_battery_low),
        laptop_battery_percent=args.laptop_battery, laptop_plugged=args.laptop_plugged,
        record_every=1 if args.render else 0)
    return configure_simulation(config, nav, occ_map)


def _error(message: object) -> None:
    """One error line on stderr, control characters shown escaped so that nothing can split it."""
    print(f"{PROG}: error: {printable(message, limit=2000)}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    try:
        # Ctrl-C or SIGTERM before the patrol runs (loading the map, setting up the planner) is remembered, not
        # fatal: the patrol then starts preempted and goes straight to SHUTDOWN, so the summary and the events
        # file are written as for a Ctrl-C later on; a second signal gives up at once (KeyboardInterrupt).
        with StopSignals() as early:  # from the first moment: a Ctrl-C while parsing counts too
            parser = build_parser()
            args = parser.parse_args(argv)
            check_limit_settings()
            return _run(parser, args, early)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted twice, stopped without shutting down cleanly", file=sys.stderr)
        return 130
    except (InputError, OutputError) as exc:  # from anywhere: a reader, a limit, a writer
        _error(exc)
        return 2


def _make_parent_folders(*paths: str | None) -> None:
    """An output's missing parent folders are made, as objrec-detect does; a path that cannot have them
    (under a regular file, in a read-only place) is an OutputError naming the output."""
    for path in paths:
        if not path:
            continue
        try:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(path, f"cannot be written: folder {Path(path).parent}: {exc.strerror or exc}") from None


def _check_output_paths(args: argparse.Namespace) -> None:
    """Every output path judged before anything is written (:mod:`strictio.output_paths`): none may replace
    the pose file, the map or its image, or a file a ``--robot`` option names; none may be read-only or a FIFO."""
    files = RunFiles().reads(args.poses, "the pose file").reads(args.map, "the map file")
    files.reads(load_map_metadata(args.map).image, "the map image")
    for path, what in nav_params_inputs(args):  # the navigation parameters and their masks
        files.reads(path, what)
    for value in parse_robot_spec(args.robot)[1].values():
        if value and os.path.lexists(value):
            files.reads(value, "a file of --robot")
    files.writes("--events", args.events, stream=True)
    files.writes("--diagram", args.diagram)
    files.writes("--render", args.render)
    if args.rerun and args.rerun != "spawn":
        files.writes("--rerun", args.rerun)


def _run(parser: argparse.ArgumentParser, args: argparse.Namespace, early: StopSignals | None = None) -> int:
    logging.basicConfig(level=logging.WARNING - 10 * min(args.verbose, 2), stream=sys.stderr,
                        format="%(levelname)s %(name)s: %(message)s")
    for option, value, kinds in (("--render", args.render, STILL + ANIMATED),):
        if value and Path(value).suffix.lower() not in kinds:
            parser.error(f"{option} {printable(value)}: the extension must be one of {', '.join(kinds)}")
    try:
        occ_map = load_map(args.map)
        pose_file = load_poses(args.poses)
    except (MapError, PoseFileError) as exc:
        _error(exc)
        return 2

    try:
        _check_output_paths(args)
    except (OutputError, RobotError) as exc:
        _error(exc)
        return 2
    station_pose = None if args.no_station else pose_file.station
    if args.start:
        start = Pose2D(*args.start)
    else:
        start = station_pose or pose_file.goals[0]
    station = DockingStation.in_front_of(station_pose, args.dock_distance) if station_pose else None
    nav = nav_params_from_args(args)
    config = _config(args, nav, occ_map)
    zones = None
    setup = RobotSetup(occ_map, start, tuple(pose_file.goals), station_pose, station, config,
                       stop_requested=lambda: early is not None and early.count > 0)
    try:
        sim = open_robot(args.robot, setup)
        if isinstance(sim, Simulation):
            zones = apply_to_simulation(sim, nav)  # the speed zones; the planner came with the config
        elif args.nav_params or args.keepout_mask or args.speed_mask or args.cost_scaling_factor is not None:
            log.warning("the navigation parameters and masks act on the simulator only; robot %s plans and drives "
                        "with its own settings", args.robot)
    except (StartPoseError, RobotError, RobotUnavailable) as exc:
        _error(exc)
        return 2
    lost_problem = apply_lost_robot_options(sim, args)
    if lost_problem:
        sim.close()
        _error(lost_problem)
        return 2
    if not isinstance(sim, Simulation) and args.rerun:
        sim.close()
        _error(f"--rerun records the simulator only; --robot {args.robot} is a live robot")
        return 2
    for i, goal in enumerate(pose_file.goals):
        if isinstance(sim, Simulation) and sim.field.collides(goal.x, goal.y, config.robot.radius):
            log.warning("goal POSE_%d (%.2f, %.2f) is off the map or in an obstacle; it will be aborted",
                        i, goal.x, goal.y)
        elif isinstance(sim, Simulation) and sim.planner.keepout is not None and in_keepout(sim.planner, goal):
            log.warning("goal POSE_%d (%.2f, %.2f) is in a keepout zone; it will be aborted", i, goal.x, goal.y)
    if args.resume_after_charging and args.laps is None and args.time_limit is None and not args.realtime:
        log.warning("--resume-after-charging without --laps or --time-limit runs until Ctrl-C or %s steps",
                    f"{MAX_STEPS:,}")

    # The laptop riding on the robot (the thesis's set-up) is watched by a monitor of this command, not of the machine.
    monitors = () if args.laptop_plugged else (laptop_battery_monitor(),)
    machine = PatrolMachine(sim, pose_file.goals, station_pose, max_laps=args.laps,
                            resume_after_charging=args.resume_after_charging, monitors=monitors)
    recorder: PatrolRecorder | None = None
    if args.rerun:
        try:
            recorder = open_patrol_rerun(args.rerun, sim, pose_file.goals, station_pose)
        except RerunUnavailable as exc:
            _error(exc)
            return 2
    view: PatrolView | None = None
    if args.foxglove:
        try:
            view = open_patrol_view(args.foxglove, sim, occ_map, machine, pose_file.goals, station_pose)
        except FoxgloveUnavailable as exc:
            if recorder is not None:
                recorder.close()
            sim.close()
            _error(exc)
            return 2
        print(f"{PROG}: Foxglove live view on {view.server.url}", file=sys.stderr, flush=True)
    try:
        _make_parent_folders(args.diagram, args.events, args.render)
        if args.diagram:  # the machine itself, so that the monitors it was given are drawn
            write_diagram(args.diagram, machine)
            machine.state_listeners.append(lambda m: write_diagram(args.diagram, m, m.active_states()))
        if args.events:
            sim.events.open(args.events)
        sim.events.keep = False  # the command streams events; holding hours of them in memory helps nobody
        if early is not None and early.count:
            machine.request_preempt(early.reason)  # Ctrl-C or SIGTERM came during start-up
        states: list[tuple[float, str]] = []
        marks = LocalizationMarks()  # the believed pose, losses and kidnaps, for --render
        if args.render:
            machine.state_listeners.append(lambda m: states.append((sim.clock.now, m.entering)))
            sim.events.subscribe(marks)
        summary = run_patrol(machine, time_limit=args.time_limit, realtime=args.realtime)
    except OSError as exc:
        _error(exc)
        return 2
    finally:
        sim.events.close()
        if recorder is not None:
            recorder.close()
        if view is not None:
            view.close()
        sim.close()
    if args.diagram:
        write_diagram(args.diagram, machine, machine.active_states())
    print(format_summary(summary))
    if args.render:
        picture = RunPicture(occ_map, sim.trajectory, pose_file.goals, station_pose, station,
                             sim.collision_points, config.robot.radius,
                             caption=f"laps {summary.laps}  goals {summary.goals_reached}/"
                                     f"{summary.goals_reached + summary.goals_aborted}  "
                                     f"{summary.distance:.0f} m  collisions {summary.collisions}",
                             states=states, zones=zones, localization=marks)
        try:
            save_render(args.render, picture)
        except (OSError, ValueError) as exc:
            _error(exc)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
