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

Errors name the file and the field (``at.1.expect[0]: ...``), as every file error of the project does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navigation.poses import PoseFile, PoseFileError, load_poses
from navigation.tasks import PoseTask, TaskSpecError, make_task
from strictio import InputError, YAMLLimits, read_yaml

from . import detect_task  # noqa: F401 - registers the "detect" task with the patrol's registry

#: A mission lists a few poses and tasks: a megabyte is plenty, and never a bomb.
MISSION_LIMITS = YAMLLimits(max_bytes=1024 * 1024, max_depth=12)
TOP_KEYS = ("poses", "first_pose", "laps", "stop_on_failure", "tolerance", "tasks", "at")
POSE_KEYS = ("tasks", "expect")
EXPECT_KEYS = ("name", "label", "tolerance")
DEFAULT_TOLERANCE = 0.5


class MissionError(ValueError):
    """A mission file that cannot be used; the message names the file and the field."""


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


class _Reader:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.base = path.parent

    def fail(self, where: str, message: str) -> MissionError:
        return MissionError(f"{self.path}: {where}: {message}" if where else f"{self.path}: {message}")

    def keys(self, data: Any, allowed: tuple[str, ...], where: str) -> dict[Any, Any]:
        if not isinstance(data, dict):
            raise self.fail(where, f"expected a mapping, got {type(data).__name__}")
        unknown = [str(k) for k in data if k not in allowed]
        if unknown:
            raise self.fail(where, f"unknown field(s) {', '.join(unknown)} (fields: {', '.join(allowed)})")
        return data

    def whole(self, value: Any, where: str, low: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.fail(where, f"expected a whole number of at least {low}, got {value!r}")
        return value

    def distance(self, value: Any, where: str) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value <= 0:
            raise self.fail(where, f"expected a positive distance in metres, got {value!r}")
        return float(value)

    def tasks(self, items: Any, where: str) -> tuple[PoseTask, ...]:
        if not isinstance(items, list):
            raise self.fail(where, f"expected a list of tasks, got {type(items).__name__}")
        built = []
        for k, item in enumerate(items):
            try:
                built.append(make_task(item, self.base))
            except TaskSpecError as exc:
                raise self.fail(f"{where}[{k}]", str(exc)) from None
        return tuple(built)

    def expected(self, items: Any, where: str, tolerance: float) -> tuple[Expected, ...]:
        if not isinstance(items, list):
            raise self.fail(where, f"expected a list of object names, got {type(items).__name__}")
        found: list[Expected] = []
        for k, item in enumerate(items):
            at = f"{where}[{k}]"
            if isinstance(item, str):
                item = {"name": item}
            entry = self.keys(item, EXPECT_KEYS, at)
            name = entry.get("name")
            if not isinstance(name, str) or not name:
                raise self.fail(f"{at}.name", f"expected an object name, got {name!r}")
            label = entry.get("label", name)
            if not isinstance(label, str) or not label:
                raise self.fail(f"{at}.label", f"expected a detection name, got {label!r}")
            tol = self.distance(entry["tolerance"], f"{at}.tolerance") if "tolerance" in entry else tolerance
            if any(e.name == name for e in found):
                raise self.fail(at, f"object {name!r} is expected twice at this pose")
            found.append(Expected(name, label, tol, at))
        return tuple(found)


def load_mission(path: str | Path) -> Mission:
    """Read and check a mission file, its pose file and every task's options (parameter files included)."""
    path = Path(path)
    try:
        data = read_yaml(path, MISSION_LIMITS)
    except InputError as exc:
        if exc.message == "file not found":
            raise MissionError(f"{path}: mission file not found") from None
        raise MissionError(str(exc)) from None
    r = _Reader(path)
    data = r.keys(data, TOP_KEYS, "")
    if "poses" not in data or not isinstance(data["poses"], str):
        raise r.fail("poses", f"required: the goal-pose file, got {data.get('poses')!r}")
    poses_path = Path(data["poses"]).expanduser()
    poses_path = poses_path if poses_path.is_absolute() else r.base / poses_path
    try:
        poses = load_poses(poses_path)
    except PoseFileError as exc:
        raise r.fail("poses", str(exc)) from None
    n = len(poses.goals)
    first = r.whole(data.get("first_pose", 0), "first_pose", 0)
    if first >= n:
        raise r.fail("first_pose", f"{first} is not one of the {n} poses of {poses_path}")
    laps = r.whole(data.get("laps", 1), "laps", 1)
    stop = data.get("stop_on_failure", False)
    if not isinstance(stop, bool):
        raise r.fail("stop_on_failure", f"expected true or false, got {stop!r}")
    tolerance = r.distance(data["tolerance"], "tolerance") if "tolerance" in data else DEFAULT_TOLERANCE
    common = r.tasks(data.get("tasks", []), "tasks")
    tasks: list[tuple[PoseTask, ...]] = [common] * n
    expected: list[tuple[Expected, ...]] = [()] * n
    at = data.get("at") or {}
    if not isinstance(at, dict):
        raise r.fail("at", f"expected a mapping of pose index to tasks and expected objects, got {at!r}")
    for index, entry in at.items():
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < n:
            raise r.fail(f"at.{index}", f"not a pose index: {poses_path} has poses 0 to {n - 1}")
        entry = r.keys(entry or {}, POSE_KEYS, f"at.{index}")
        if "tasks" in entry:
            tasks[index] = r.tasks(entry["tasks"] or [], f"at.{index}.tasks")
        expected[index] = r.expected(entry.get("expect") or [], f"at.{index}.expect", tolerance)
    return Mission(path, poses_path, poses, tuple(tasks), tuple(expected), first, laps, stop, tolerance)
