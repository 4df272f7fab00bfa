"""The lost-robot lessons on the command line: ``--initial-pose`` (with ``--initial-spread``) and ``--kidnap``.

``--initial-pose X Y YAW`` is rviz's "2D Pose Estimate": amcl starts with a cloud around a pose the user
gives, which need not be where the robot stands (``--start``); ``--initial-spread`` is the cloud's standard
deviation, amcl's ``initial_cov`` (0.5 m and pi/12 rad by default, for a click). ``--kidnap T X Y YAW`` carries
the true robot to (X, Y, YAW) at simulated time T without telling its odometry or amcl: the kidnapped-robot
problem, which only a filter that notices it is lost (and the patrol's LOCALIZE state) survives.
"""

from __future__ import annotations

import argparse
import math

from strictio.cli_numbers import Number, fields

from .geometry import Pose2D
from .localization import Amcl
from .relocalize import schedule_kidnap
from .simulation import Simulation

COORDINATE = Number(-1e6, 1e6)  # metres in the map frame
YAW = Number(-math.tau, math.tau)  # radians
SPREAD_XY = Number(0, 10)  # metres
SPREAD_YAW = Number(0, math.tau)  # radians
KIDNAP_TIME = Number(0, 1e7)  # simulated seconds
DEFAULT_SPREAD = (0.5, math.pi / 12)


def add_lost_robot_options(parser: argparse.ArgumentParser) -> argparse._ArgumentGroup:
    """The ``lost robot`` group: --initial-pose, --initial-spread, --kidnap."""
    g = parser.add_argument_group(
        "lost robot", "The initial-pose and kidnapped-robot lessons (with --localization amcl); a lost amcl sends "
        "the patrol into LOCALIZE: see docs/navigation.md.")
    g.add_argument("--initial-pose", nargs=3, action=fields(COORDINATE, COORDINATE, YAW), metavar=("X", "Y", "YAW"),
                   help="where amcl believes the robot starts (rviz's 2D Pose Estimate; default: the true start)")
    g.add_argument("--initial-spread", nargs=2, action=fields(SPREAD_XY, SPREAD_YAW), metavar=("METRES", "RADIANS"),
                   help=f"standard deviation of amcl's cloud around --initial-pose (default {DEFAULT_SPREAD[0]:g} "
                        f"{DEFAULT_SPREAD[1]:.2f}, amcl's initial_cov)")
    g.add_argument("--kidnap", nargs=4, action=fields(KIDNAP_TIME, COORDINATE, COORDINATE, YAW),
                   metavar=("T", "X", "Y", "YAW"),
                   help="teleport the true robot to X Y YAW at simulated time T; odometry and amcl are not told")
    return g


def apply_lost_robot_options(robot: object, args: argparse.Namespace) -> str:
    """Set amcl's initial cloud and schedule the kidnap on the simulator; "" or one line saying what is wrong."""
    initial = getattr(args, "initial_pose", None)
    spread = getattr(args, "initial_spread", None)
    kidnap = getattr(args, "kidnap", None)
    if not (initial or spread or kidnap):
        return ""
    if not isinstance(robot, Simulation):
        return "--initial-pose, --initial-spread and --kidnap need the simulator (--robot sim)"
    if initial or spread:
        if not isinstance(robot.localizer, Amcl):
            return "--initial-pose and --initial-spread need --localization amcl"
        pose = Pose2D(*initial) if initial else robot.start
        sxy, syaw = spread or DEFAULT_SPREAD
        robot.localizer.set_pose(pose, sxy, syaw)
    if kidnap:
        t, x, y, yaw = kidnap
        try:
            schedule_kidnap(robot, t, Pose2D(x, y, yaw))
        except ValueError as exc:
            return f"--kidnap: {exc}"
    return ""
