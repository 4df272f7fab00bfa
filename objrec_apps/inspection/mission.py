"""The mission file: which poses to visit, what to do at each, and which objects must be there.

A YAML file, read through strictio; paths in it are relative to the file::

    poses: lab_poses.txt            # goal poses (the patrol's pose-file format)
    first_pose: 0                   # where the patrol starts (default 0)
    laps: 1                         # how many laps (default 1; objrec-inspect --laps overrides)
    stop_on_failure: false          # an aborted goal or task ends the mission (default false)
    tolerance: 0.5                  # metres: found farther than this from the world file is "moved"
    tasks:                          # done at every pose that does not list its own
      - detect: params/shapes_3d.yaml
    at:                             # per pose, by its index in the pose file
      0:
        tasks: [{look_around: [-20, 0, 20]}, {detect: params/shapes_3d.yaml}]
        expect: [green_cylinder]    # names of world-file objects, found under the same name
      1:
        expect: [{name: poster, label: poster, tolerance: 0.6}]

The file is read against a table of declared fields (:data:`MISSION_FIELDS`), so errors name the file, the
line and the key path (``mission.yaml:14: at.1.expect[0].tolerance: -1 is invalid: out of range, allowed float
in (0..1000000]``), as every file error of the project does, down to a task's options (``at.0.tasks[1].wait.seconds``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from declare import Bool, Float, Int, Str
from declare.fields import DocumentError, FilePath, Free, ListOf, MapOf, Place, Record, Value, not_blank
from declare.fields import read_document as read_yaml_document
from navigation.poses import PoseFile, load_poses
from navigation.tasks import PoseTask, make_task
from strictio import YAMLLimits
from strictio.limits import MISSION_TASKS, check

from . import detect_task  # noqa: F401 - registers the "detect" task with the patrol's registry

#: A mission lists a few poses and tasks: a megabyte is plenty, and never a bomb.
MISSION_LIMITS = YAMLLimits(max_bytes=1024 * 1024, max_depth=12)
DEFAULT_TOLERANCE = 0.5
#: The most laps a mission may ask for: objrec-inspect's and objrec-patrol's own --laps bound.
MAX_LAPS = 100_000

#: A mission file that cannot be used: the one error of every file reader (file, line, key path, value, rule).
MissionError = DocumentError


class _Task(Free):
    """One entry of a task list, built (and its options checked) by the patrol's task registry."""

    def __init__(self) -> None:
        super().__init__(required=True, what="a task name or a one-key mapping (task: options)")

    def convert(self, value: Any, at: Place) -> PoseTask:
        return make_task(value, at.document.folder, at)


_TASKS = ListOf(_Task(), null_is_empty=True, default=None, doc="tasks done at the pose, in order")
_DISTANCE = Float(DEFAULT_TOLERANCE, "metres", min=0.0, min_open=True, max=1e6)
_EXPECT = Record({
    "name": Value(Str("", "the object's name in the world file"), required=True, check=not_blank),
    "label": Value(Str("", "the name detections give it (default: its name)"), default=None, check=not_blank),
    "tolerance": Value(_DISTANCE, default=None),
}, shorthand="name")

#: What a mission file holds; pose indices are checked against the pose file once it is read.
MISSION_FIELDS = Record({
    "poses": FilePath(required=True, doc="the goal-pose file"),
    "first_pose": Int(0, "the pose the patrol starts at", min=0),
    "laps": Int(1, "how many laps", min=1, max=MAX_LAPS),
    "stop_on_failure": Bool(False, "an aborted goal or task ends the mission"),
    "tolerance": Value(_DISTANCE),
    "tasks": _TASKS,
    "at": MapOf(Int(0, "a pose index", min=0),
                Record({"tasks": _TASKS, "expect": ListOf(_EXPECT, null_is_empty=True)}, null_is_empty=True),
                null_is_empty=True),
})


@dataclass(frozen=True)
class Expected:
    """An object that must be at a pose: ``name`` in the world file, found by detections named ``label``."""

    name: str
    label: str
    tolerance: float
    where: str  # the field it came from, for later errors (an unknown world object)


@dataclass(frozen=True)
class Mission:
    path: Path
    poses_path: Path
    poses: PoseFile
    tasks: tuple[tuple[PoseTask, ...], ...]
    expected: tuple[tuple[Expected, ...], ...]
    first_pose: int = 0
    laps: int = 1
    stop_on_failure: bool = False
    tolerance: float = DEFAULT_TOLERANCE


def _expected(items: tuple[dict[str, Any], ...], at: Place, tolerance: float) -> tuple[Expected, ...]:
    found: list[Expected] = []
    for k, item in enumerate(items):
        name = item["name"]
        if any(e.name == name for e in found):
            raise at.item(k).fail(f"object {name!r} is expected twice at this pose")
        tol = item["tolerance"] if item["tolerance"] is not None else tolerance
        found.append(Expected(name, item["label"] or name, tol, at.item(k).shown))
    return tuple(found)


def _listed_tasks(data: Any) -> int:
    """How many tasks a mission file lists (its ``tasks`` and every pose's), counted before any is built: each
    ``detect`` builds a recognition system and runs it at every visit, so 20,000 of them would keep the patrol
    busy for hours."""
    if not isinstance(data, dict):
        return 0
    lists = [data.get("tasks")]
    if isinstance(data.get("at"), dict):
        lists += [entry.get("tasks") for entry in data["at"].values() if isinstance(entry, dict)]
    return sum(len(tasks) for tasks in lists if isinstance(tasks, list))


def load_mission(path: str | Path) -> Mission:
    """Read and check a mission file, its pose file and every task's options (parameter files included)."""
    document = read_yaml_document(path, MISSION_LIMITS, "mission")
    root = document.root
    check(document.path, MISSION_TASKS, _listed_tasks(document.data), "tasks listed")
    data = MISSION_FIELDS.read(document.data, root)
    poses_path: Path = data["poses"]
    poses = load_poses(poses_path)
    n = len(poses.goals)
    first = data["first_pose"]
    if first >= n:
        raise root.key("first_pose").fail(f"not one of the {n} poses of {poses_path}", first)
    tasks: list[tuple[PoseTask, ...]] = [data["tasks"] or ()] * n
    expected: list[tuple[Expected, ...]] = [()] * n
    for index, entry in data["at"].items():
        at = root.key("at").key(index)
        if index >= n:
            raise at.fail(f"not a pose index: {poses_path} has poses 0 to {n - 1}", index)
        if entry["tasks"] is not None:
            tasks[index] = entry["tasks"]
        expected[index] = _expected(entry["expect"], at.key("expect"), data["tolerance"])
    return Mission(document.path, poses_path, poses, tuple(tasks), tuple(expected), first, data["laps"],
                   data["stop_on_failure"], data["tolerance"])
