"""``objrec-inspect MISSION --map MAP --world WORLD``: the inspection patrol in the built-in simulator.

The robot visits the mission's poses, runs the tasks there (wait, photo, look_around, detect with any
parameter file) on its simulated RGB-D camera, and reports per visit what it found where and whether each
expected object is present, absent or moved. Output folder (``--out``): ``events.jsonl``, ``report.json``,
``report.md``, ``map.png`` and ``photos/``. The summary goes to stdout, diagnostics to stderr; a file that
cannot be used, an option's value out of its declared range or an output that cannot be written is one error
line naming the file (or option) and why, exit code 2. Ctrl-C or SIGTERM (also during start-up) ends the patrol
in SHUTDOWN and writes the report so far, exit code 0; a second one gives up (130).
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

from foxgloveio.server import FoxgloveUnavailable, add_foxglove_argument
from navigation.cli import COORDINATE, LAPS, TIME_LIMIT, YAW, format_summary
from navigation.diagram import write_diagram
from navigation.geometry import Pose2D
from navigation.maps import load_map_metadata
from navigation.nav_params import add_nav_params_options, in_keepout, nav_params_from_args, nav_params_inputs
from navigation.runner import Summary
from navigation.sim_options import add_simulation_options, simulation_config
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, Number, check_limit_settings, fields
from strictio.output_paths import RunFiles
from strictio.signals import StopSignals

from .cli import USER_ERROR, configure_logging, report
from .foxglove_inspection import InspectionView
from .inspection import Inspection, InspectionError, open_inspection

log = logging.getLogger("objrec.inspect")
PROG = "objrec-inspect"


#: How far --shift may move an object, in metres.
SHIFT = Number(-1000, 1000)


def build_parser() -> argparse.ArgumentParser:
    p = CommandLineParser(
        prog=PROG,
        description="Drive the poses of a mission in a simulated world, run its tasks with the robot's RGB-D "
                    "camera (wait, photo, look_around, detect) and report, per visit, the objects found with "
                    "their map positions and whether each expected object is present, absent or moved.")
    p.add_argument("mission", metavar="MISSION", help="mission file (YAML): pose file, tasks, expected objects")
    p.add_argument("--map", required=True, metavar="MAP_YAML", help="ROS map_server YAML file")
    p.add_argument("--world", required=True, metavar="WORLD_YAML", help="world file: objects and obstacles")
    p.add_argument("--out", default="inspection", metavar="DIR",
                   help="output folder: events.jsonl, report.json, report.md, map.png, photos/ (default inspection)")
    p.add_argument("--laps", type=LAPS, metavar="N",
                   help=f"laps of the poses (default: the mission's, else 1; {LAPS.describe()})")
    p.add_argument("--time-limit", type=TIME_LIMIT, metavar="SECONDS", help="preempt after this much simulated time")
    p.add_argument("--start", nargs=3, action=fields(COORDINATE, COORDINATE, YAW), metavar=("X", "Y", "YAW"),
                   help="start pose, metres and radians (default: the pose file's station pose, else the first "
                        "pose)")
    change = p.add_argument_group("a world different from the world file (to try the absent and moved reports)")
    change.add_argument("--remove", action="append", default=[], metavar="NAME",
                        help="the robot meets the world without this object (repeatable)")
    change.add_argument("--shift", action=fields(None, SHIFT, SHIFT, append=True), nargs=3, default=[],
                        metavar=("NAME", "DX", "DY"),
                        help="the robot meets this object shifted by DX, DY metres (repeatable)")
    add_simulation_options(p)
    add_nav_params_options(p)
    p.add_argument("--diagram", metavar="PATH", help="Mermaid diagram of the machine with the mission's states")
    add_foxglove_argument(p)
    p.add_argument("-v", "--verbose", action="store_true", help="log progress on stderr")
    return p


def _open(args: argparse.Namespace) -> Inspection:
    out = Path(args.out)
    _named_files(args).writes("--out", out, folder=True, names=None)  # before the folder is made
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InspectionError(f"{out}: cannot be created: {exc.strerror or exc}") from None
    config = simulation_config(args)
    nav = nav_params_from_args(args)  # the parameters file under the command line's options, as objrec-patrol
    inspection = open_inspection(args.mission, args.map, args.world, remove=args.remove,
                                 shift=[(name, dx, dy) for name, dx, dy in args.shift],
                                 config=config, start=Pose2D(*args.start) if args.start else None, laps=args.laps,
                                 out_dir=out, nav=nav)
    _check_output_paths(args, inspection)
    _warn_unreachable_goals(inspection)
    return inspection


def _warn_unreachable_goals(inspection: Inspection) -> None:
    """Warn, as objrec-patrol does, about a goal the robot cannot stand on: off the map, in one of its
    obstacles, in an object or obstacle of the world it drives in, or in a keepout zone. Its goal will be
    aborted."""
    radius = inspection.sim.config.robot.radius
    for i, goal in enumerate(inspection.machine.goals):
        inside = inspection.world.colliding(goal.x, goal.y, radius)
        if inside:
            log.warning("goal POSE_%d (%.2f, %.2f) is inside %s of the world; it will be aborted", i, goal.x,
                        goal.y, ", ".join(repr(name) for name in inside))
        elif inspection.sim.field.collides(goal.x, goal.y, radius):
            log.warning("goal POSE_%d (%.2f, %.2f) is off the map or in an obstacle; it will be aborted",
                        i, goal.x, goal.y)
        elif in_keepout(inspection.sim.planner, goal):
            log.warning("goal POSE_%d (%.2f, %.2f) is in a keepout zone; it will be aborted", i, goal.x, goal.y)


#: What the inspection writes into ``--out`` (besides ``photos/``), each checked before the run.
OUT_FILES = ("events.jsonl", "report.json", "report.md", "map.png")


def _named_files(args: argparse.Namespace) -> RunFiles:
    """The inputs named on the command line: the mission, map and world files."""
    return (RunFiles().reads(args.mission, "the mission file").reads(args.map, "the map file")
            .reads(args.world, "the world file"))


def _check_output_paths(args: argparse.Namespace, inspection: Inspection) -> None:
    """Every output judged before anything is written (:mod:`strictio.output_paths`): none may replace the
    mission, its pose file or a task's parameter file, the map, its image, the world file or a poster's picture;
    none may be read-only or a FIFO, or lead out of ``--out`` through a link."""
    mission = inspection.mission
    files = _named_files(args).reads(mission.poses_path, "the pose file")
    files.reads(load_map_metadata(args.map).image, "the map image")
    for path, what in nav_params_inputs(args):  # the navigation parameters and their masks
        files.reads(path, what)
    world = inspection.reference
    for thing in (*world.objects, *world.obstacles):
        files.reads(getattr(thing, "image_path", None), f"the picture of {thing.name} in the world file")
    for task in (task for tasks in mission.tasks for task in tasks):
        for value in task.values.values():
            if isinstance(value, Path):
                files.reads(value, f"a file of the {task.kind} task")
    out = Path(args.out)
    files.writes("--out", out, folder=True, names=None)
    for name in OUT_FILES:
        files.writes(f"{name} in --out", out / name, inside=out, stream=name.endswith(".jsonl"))
    files.writes("photos/ in --out", out / "photos", folder=True, inside=out)
    files.writes("--diagram", args.diagram)


def _verdict_lines(inspection: Inspection, summary: Summary) -> list[str]:
    """One line per expected object, as the report has it (a "not checked" one says why)."""
    lines = []
    for name, (visit, v) in inspection.report.verdicts(summary.as_dict()).items():
        where = "" if v.found is None else f" at ({v.found.x:.2f}, {v.found.y:.2f}), {v.error:.2f} m off"
        why = f": {v.reason}" if v.reason else ""
        lines.append(f"{name + ':':16s}{v.status.replace('_', ' ')}{where}{why}"
                     + ("" if visit is None else f" (visit {visit})"))
    return lines


def run(args: argparse.Namespace, early: StopSignals) -> int:
    inspection = _open(args)
    sim, machine = inspection.sim, inspection.machine
    out = Path(args.out)
    view: InspectionView | None = None
    if args.foxglove:
        try:
            view = InspectionView(args.foxglove, inspection)
        except FoxgloveUnavailable as exc:
            raise InspectionError(str(exc)) from None
        sys.stderr.write(f"{PROG}: Foxglove live view on {view.url}\n")
        sys.stderr.flush()
    try:
        if args.diagram:
            write_diagram(args.diagram, machine)
            machine.state_listeners.append(lambda m: write_diagram(args.diagram, m, m.active_states()))
        sim.events.open(out / "events.jsonl")
        sim.events.keep = False
        if early.count:
            machine.request_preempt(early.reason)  # Ctrl-C or SIGTERM came during start-up
        summary = inspection.run(time_limit=args.time_limit, realtime=args.realtime)
    except OutputError:
        raise  # already names its file
    except OSError as exc:
        raise InspectionError(f"{exc.filename or out}: cannot be written: {exc.strerror or exc}") from None
    finally:
        sim.events.close()
        if view is not None:
            view.close()
    written = inspection.write(summary)
    sys.stdout.write(format_summary(summary) + "\n" + "\n".join(_verdict_lines(inspection, summary)) + "\n")
    sys.stdout.write(f"{'report:':16s}{written[1]}\n")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    try:
        with StopSignals() as early:  # from the first moment: a Ctrl-C while parsing counts too
            args = build_parser().parse_args(argv)
            configure_logging(PROG, args.verbose)
            check_limit_settings()
            return run(args, early)
    except (InspectionError, InputError, OutputError) as exc:  # a reader's, a limit's or a writer's, from anywhere
        report(PROG, exc)
        return USER_ERROR
    except KeyboardInterrupt:
        report(PROG, "interrupted twice, stopped without shutting down cleanly")
        return 130


if __name__ == "__main__":
    sys.exit(main())
