"""``objrec-patrol POSES_FILE --map MAP_YAML``: run the inspection patrol in the built-in simulator.

Results (the summary) go to stdout, diagnostics to stderr. A map or pose file that cannot be used gives
one error line naming the file and the line or field, and exit code 2.
"""

from __future__ import annotations

import argparse
import logging
import math
import signal
import sys
import threading
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from types import FrameType
from typing import Any

from rerunio import RerunUnavailable

from .battery import LaptopBatteryParams, RobotBatteryParams, kobuki_percent, kobuki_voltage
from .diagram import write_diagram
from .docking import DockingStation
from .geometry import Pose2D
from .localization import LOCALIZATION_MODES
from .maps import MapError, load_map
from .patrol import PatrolMachine
from .poses import PoseFileError, load_poses
from .render import ANIMATED, STILL, RunPicture, save_render
from .rerun_log import PatrolRecorder, open_patrol_rerun
from .runner import Summary, run_patrol
from .simulation import SimConfig, Simulation, StartPoseError

log = logging.getLogger("navigation.cli")
PROG = "objrec-patrol"


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0 or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def _percent(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= 100.0:
        raise argparse.ArgumentTypeError(f"must be a percentage in 0..100, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Patrol the goal poses of POSES_FILE on a ROS map in a built-in 2D simulator, with the "
                    "patrol state machine (battery monitors, docking, shutdown).")
    p.add_argument("poses", metavar="POSES_FILE", help="goal poses, one 'x, y, z, qx, qy, qz, qw' per line")
    p.add_argument("--map", required=True, metavar="MAP_YAML", help="ROS map_server YAML file")
    p.add_argument("--start", nargs=3, type=float, metavar=("X", "Y", "YAW"),
                   help="start pose in the map frame (default: the station pose, else the first goal)")
    stop = p.add_argument_group("when to stop (default: when the machine ends by itself, or Ctrl-C)")
    stop.add_argument("--laps", type=int, metavar="N", help="end after N laps of the goals")
    stop.add_argument("--time-limit", type=_positive, metavar="SECONDS",
                      help="preempt after this much simulated time")
    bat = p.add_argument_group("batteries")
    bat.add_argument("--robot-battery", type=_percent, default=100.0, metavar="PERCENT",
                     help="robot battery at the start (default 100)")
    bat.add_argument("--robot-battery-low", type=_percent, metavar="PERCENT",
                     help=f"robot low threshold (default {kobuki_percent(14.0):.0f}, the Kobuki's 14.0 V)")
    bat.add_argument("--robot-runtime", type=_positive, default=3.0, metavar="HOURS",
                     help="robot driving time on a full battery (default 3)")
    bat.add_argument("--robot-charge-time", type=_positive, default=1.5, metavar="HOURS",
                     help="time on the dock from empty to full (default 1.5)")
    bat.add_argument("--laptop-battery", type=_percent, default=100.0, metavar="PERCENT",
                     help="laptop battery at the start (default 100)")
    bat.add_argument("--laptop-battery-low", type=_percent, default=20.0, metavar="PERCENT",
                     help="laptop low threshold (default 20)")
    bat.add_argument("--laptop-runtime", type=_positive, default=2.5, metavar="HOURS",
                     help="laptop time on battery (default 2.5)")
    bat.add_argument("--laptop-plugged", action="store_true", help="the laptop is on mains power")
    dock = p.add_argument_group("docking")
    dock.add_argument("--no-station", action="store_true", help="ignore the station pose in POSES_FILE")
    dock.add_argument("--dock-distance", type=_positive, default=1.0, metavar="METRES",
                      help="distance from the station pose to the dock ahead of it (default 1.0)")
    dock.add_argument("--resume-after-charging", action="store_true",
                      help="undock and patrol on when charged, instead of shutting down")
    sim = p.add_argument_group("simulation")
    sim.add_argument("--seed", type=int, default=0, help="random seed for sensor noise (default 0)")
    sim.add_argument("--odom-noise", type=float, default=0.0, metavar="FRACTION",
                     help="relative odometry noise per step, e.g. 0.02 (default 0)")
    sim.add_argument("--localization", choices=LOCALIZATION_MODES, default="exact",
                     help="pose the navigation drives on: exact (the true pose, default), amcl (a particle filter "
                          "matching laser scans to the map), odometry (dead reckoning alone)")
    sim.add_argument("--dt", type=_positive, default=0.1, metavar="SECONDS", help="time step (default 0.1)")
    sim.add_argument("--realtime", action="store_true", help="run at wall-clock speed instead of flat out")
    sim.add_argument("--margin", type=float, default=0.10, metavar="METRES",
                     help="obstacle inflation beyond the robot radius for planning (default 0.10)")
    out = p.add_argument_group("output")
    out.add_argument("--events", metavar="FILE", help="write every event as JSON Lines")
    out.add_argument("--render", metavar="PATH",
                     help=f"picture of the run ({', '.join(STILL)}) or animation ({', '.join(ANIMATED)})")
    out.add_argument("--diagram", metavar="PATH",
                     help="Mermaid diagram of the machine, active states marked, kept up to date (.md: fenced)")
    out.add_argument("--rerun", metavar="FILE.rrd|spawn",
                     help="record the map, the robot's pose and path, scans, goals and state changes for the "
                          "Rerun viewer: a .rrd file, or spawn to open the viewer (needs objrec[viz])")
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
        ("simulated time", f"{_format_time(summary.sim_time)} ({summary.sim_time:.1f} s) in "
                           f"{summary.wall_time:.2f} s wall ({summary.speedup:.0f}x real time)"),
        ("laps", str(summary.laps)),
        ("goals", f"{summary.goals_reached} reached, {summary.goals_aborted} aborted, "
                  f"{summary.goals_preempted} preempted"),
        ("distance", f"{summary.distance:.1f} m (odometry drifted {summary.odometry_drift:.2f} m)"),
        ("localization", _format_localization(summary)),
        ("collisions", str(summary.collisions)),
        ("robot battery", f"{summary.robot_battery:.1f} %"),
        ("laptop battery", f"{summary.laptop_battery:.1f} %"),
    ]
    return "\n".join(f"{k + ':':16s}{v}" for k, v in rows)


def _format_localization(summary: Summary) -> str:
    if summary.localization == "exact":
        return "exact (navigation sees the true pose)"
    updates = f", {summary.localization_updates} filter updates" if summary.localization == "amcl" else ""
    return (f"{summary.localization}: estimate off by {summary.localization_error_mean:.3f} m on average, "
            f"{summary.localization_error_max:.3f} m at most{updates}")


def _config(args: argparse.Namespace) -> SimConfig:
    base = SimConfig()
    robot_low = args.robot_battery_low
    robot_params = RobotBatteryParams(
        runtime_h=args.robot_runtime, charge_time_h=args.robot_charge_time,
        low_voltage=kobuki_voltage(robot_low) if robot_low is not None else base.robot_battery.low_voltage)
    return replace(
        base, dt=args.dt, inflation_margin=args.margin, seed=args.seed,
        odom_linear_noise=args.odom_noise, odom_angular_noise=args.odom_noise,
        robot_battery=robot_params, robot_battery_percent=args.robot_battery,
        laptop_battery=LaptopBatteryParams(runtime_h=args.laptop_runtime, low_percent=args.laptop_battery_low),
        laptop_battery_percent=args.laptop_battery, laptop_plugged=args.laptop_plugged,
        record_every=1 if args.render else 0, localization=args.localization)


class StartupSigint:
    """Ctrl-C before the patrol runs (loading the map, setting up the planner) is remembered, not fatal.

    The patrol then starts preempted and goes straight to SHUTDOWN, so the summary and the events file
    are written as for a Ctrl-C later on; a second Ctrl-C gives up at once (KeyboardInterrupt).
    """

    def __init__(self) -> None:
        self.count = 0
        self._previous: Any = None

    def __enter__(self) -> StartupSigint:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def _handle(self, _signum: int, _frame: FrameType | None) -> None:
        self.count += 1
        if self.count > 1:
            raise KeyboardInterrupt

    def __exit__(self, *_exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with StartupSigint() as early:
            return _run(parser, args, early)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted twice, stopped without shutting down cleanly", file=sys.stderr)
        return 130


def _run(parser: argparse.ArgumentParser, args: argparse.Namespace, early: StartupSigint | None = None) -> int:
    logging.basicConfig(level=logging.WARNING - 10 * min(args.verbose, 2), stream=sys.stderr,
                        format="%(levelname)s %(name)s: %(message)s")
    if args.laps is not None and args.laps < 1:
        parser.error(f"--laps must be at least 1, got {args.laps}")
    for option, value, kinds in (("--render", args.render, STILL + ANIMATED),):
        if value and Path(value).suffix.lower() not in kinds:
            parser.error(f"{option} {value}: the extension must be one of {', '.join(kinds)}")
    try:
        occ_map = load_map(args.map)
        pose_file = load_poses(args.poses)
    except (MapError, PoseFileError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2

    station_pose = None if args.no_station else pose_file.station
    if args.start:
        start = Pose2D(*args.start)
    else:
        start = station_pose or pose_file.goals[0]
    station = DockingStation.in_front_of(station_pose, args.dock_distance) if station_pose else None
    config = _config(args)
    try:
        sim = Simulation(occ_map, start, config, station=station)
    except StartPoseError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    for i, goal in enumerate(pose_file.goals):
        if sim.field.collides(goal.x, goal.y, config.robot.radius):
            log.warning("goal POSE_%d (%.2f, %.2f) is off the map or in an obstacle; it will be aborted",
                        i, goal.x, goal.y)
    if args.resume_after_charging and args.laps is None and args.time_limit is None and not args.realtime:
        log.warning("--resume-after-charging without --laps or --time-limit runs until Ctrl-C")

    machine = PatrolMachine(sim, pose_file.goals, station_pose, max_laps=args.laps,
                            resume_after_charging=args.resume_after_charging)
    recorder: PatrolRecorder | None = None
    if args.rerun:
        try:
            recorder = open_patrol_rerun(args.rerun, sim, pose_file.goals, station_pose)
        except RerunUnavailable as exc:
            print(f"{PROG}: error: {exc}", file=sys.stderr)
            return 2
    try:
        if args.diagram:
            n = len(pose_file.goals)
            write_diagram(args.diagram, n)
            machine.state_listeners.append(lambda m: write_diagram(args.diagram, n, m.active_states()))
        if args.events:
            sim.events.open(args.events)
        sim.events.keep = False  # the command streams events; holding hours of them in memory helps nobody
        if early is not None and early.count:
            machine.request_preempt("SIGINT")  # Ctrl-C came during start-up
        states: list[tuple[float, str]] = []
        if args.render:
            machine.state_listeners.append(lambda m: states.append((sim.clock.now, m.entering)))
        summary = run_patrol(machine, time_limit=args.time_limit, realtime=args.realtime)
    except OSError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        sim.events.close()
        if recorder is not None:
            recorder.close()
    if args.diagram:
        write_diagram(args.diagram, len(pose_file.goals), machine.active_states())
    print(format_summary(summary))
    if args.render:
        picture = RunPicture(occ_map, sim.trajectory, pose_file.goals, station_pose, station,
                             sim.collision_points, config.robot.radius,
                             caption=f"laps {summary.laps}  goals {summary.goals_reached}/"
                                     f"{summary.goals_reached + summary.goals_aborted}  "
                                     f"{summary.distance:.0f} m  collisions {summary.collisions}",
                             states=states)
        try:
            save_render(args.render, picture)
        except (OSError, ValueError) as exc:
            print(f"{PROG}: error: {exc}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
