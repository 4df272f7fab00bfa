"""Robots the patrol can drive, as plug-ins: ``--robot sim`` (the built-in simulator, the default) or a live one.

A robot plug-in is a class with a ``name``, a one-line ``summary``, the ``options`` its ``--robot`` spec takes
(name -> what it means) and a classmethod ``open(setup, options)`` that returns a
:class:`~navigation.robot_interface.PatrolRobot`. Installed packages add robots through the ``objrec.robots``
entry-point group (``ros1 = "objrec_apps.ros1_robot:Ros1Robot"``): navigation itself knows nothing of ROS, and
a run on the simulator never imports a transport.

A spec is the robot's name, then comma-separated ``key=value`` options: ``ros1,master=http://robot:11311,
pose=/amcl_pose``. An unknown robot or option is a :class:`RobotError`, one line naming it and what is known.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from declare.registry import Registry

from .docking import DockingStation
from .geometry import Pose2D
from .maps import OccupancyMap
from .robot_interface import PatrolRobot
from .simulation import SimConfig, Simulation

ROBOT_GROUP = "objrec.robots"
DEFAULT_ROBOT = "sim"
_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class RobotError(ValueError):
    """A ``--robot`` spec that cannot be used: an unknown robot, an unknown or repeated option, a bad value."""


class RobotUnavailable(RuntimeError):
    """A robot that cannot be reached or set up (a ROS master that does not answer, a topic never seen):
    one line naming the address or topic and what to check."""


@dataclass(frozen=True)
class RobotSetup:
    """What the command knows before a robot is opened: the map and poses of the patrol and the simulator's
    settings (a live robot uses what applies to it, e.g. the battery thresholds, and ignores the rest)."""

    map: OccupancyMap
    start: Pose2D
    goals: tuple[Pose2D, ...]
    station_pose: Pose2D | None
    station: DockingStation | None
    config: SimConfig
    #: True once the user asked to stop (Ctrl-C during start-up): a robot waiting for its peers stops waiting and
    #: returns what it has, and the patrol then starts preempted and shuts down at once.
    stop_requested: Callable[[], bool] = lambda: False


class SimulatedRobot:
    """``--robot sim``: the built-in simulator (:class:`~navigation.simulation.Simulation`)."""

    name: ClassVar[str] = "sim"
    summary: ClassVar[str] = "the built-in 2D simulator (the default); its settings are the simulation options"
    options: ClassVar[Mapping[str, str]] = {}

    @classmethod
    def open(cls, setup: RobotSetup, options: Mapping[str, str]) -> PatrolRobot:
        return Simulation(setup.map, setup.start, setup.config, station=setup.station)


def _valid_robot(name: str, obj: Any) -> Any:
    if not (isinstance(obj, type) and callable(getattr(obj, "open", None))
            and isinstance(getattr(obj, "options", None), Mapping)):
        raise TypeError(f"robot {name}: {obj!r} is not a robot class (needs open(setup, options) and options)")
    return obj


#: The robots by name: ``sim`` here, others from the ``objrec.robots`` entry points.
ROBOTS: Registry[Any] = Registry(ROBOT_GROUP, "robot", error=RobotError, validate=_valid_robot,
                                 name_of=lambda cls: cls.name)


def parse_robot_spec(text: str) -> tuple[str, dict[str, str]]:
    """``"ros1,master=http://h:11311"`` -> ``("ros1", {"master": "http://h:11311"})``; RobotError when malformed."""
    name, _, rest = text.strip().partition(",")
    name = name.strip().lower()
    if not name or not _KEY.fullmatch(name):
        raise RobotError(f"--robot {text!r}: expected a robot name first, e.g. sim or ros1,master=URI")
    options: dict[str, str] = {}
    for part in rest.split(",") if rest.strip() else []:
        key, sep, value = part.partition("=")
        key = key.strip()
        if not sep or not _KEY.fullmatch(key):
            raise RobotError(f"--robot {text!r}: {part.strip()!r} is not key=value")
        if key in options:
            raise RobotError(f"--robot {text!r}: option {key} is given twice")
        options[key] = value.strip()
    return name, options


def robot_names() -> list[str]:
    """Every robot known: the built-in ones and the installed plug-ins."""
    return sorted(set(ROBOTS.names()) | {DEFAULT_ROBOT})


def robot_class(name: str) -> Any:
    """The plug-in class of robot ``name``; RobotError naming the known robots when there is none."""
    if name not in ROBOTS:
        raise RobotError(f"--robot {name}: no such robot (known: {', '.join(robot_names())})")
    return ROBOTS.get(name)


def open_robot(spec: str, setup: RobotSetup) -> PatrolRobot:
    """The robot a ``--robot`` spec names, opened for ``setup``; RobotError for a bad spec, RobotUnavailable
    (or the simulator's StartPoseError) when it cannot be set up."""
    name, options = parse_robot_spec(spec)
    cls = robot_class(name)
    unknown = sorted(set(options) - set(cls.options))
    if unknown:
        known = ", ".join(sorted(cls.options)) or "none"
        raise RobotError(f"--robot {spec}: robot {name} has no option {', '.join(unknown)} (options: {known})")
    robot: PatrolRobot = cls.open(setup, options)
    return robot


ROBOTS.register(SimulatedRobot)
