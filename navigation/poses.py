"""The goal-pose file: one ``x, y, z, qx, qy, qz, qw`` per line, in driving order.

``#`` starts a comment, blank lines are ignored, and an optional ``station_pose:`` line gives the pose
about one metre in front of the docking station (it may be left empty when there is no station).
Orientations are quaternions because the poses were read off ROS (amcl); only the yaw matters here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from declare import Float
from declare.fields import Document, DocumentError, Invalid, Place, Value, Vector, document_error
from strictio import POSES, InputError, read_text
from strictio.limits import check

from .geometry import Pose2D, quaternion_from_yaw, yaw_from_quaternion
from .maps import MAX_COORDINATE

#: A pose file holds one line per goal: 4 MiB is tens of thousands of goals.
POSE_FILE_LIMIT = 4 * 1024 * 1024

STATION_KEY = "station_pose:"


#: A goal-pose file that cannot be used: the one error of every file reader (file, line, key path, value, rule).
PoseFileError = DocumentError


class _TextNumber(Value):
    """A number written as text in a pose line, then checked by its declaration (finite, within bounds)."""

    def convert(self, value: Any, at: Place) -> float:
        try:
            number = float(value)
        except ValueError:
            raise Invalid("expected a number") from None
        return float(super().convert(number, at))


_NAMES = ("x", "y", "z", "qx", "qy", "qz", "qw")
#: One line of a pose file: seven comma-separated numbers, each finite and within ±MAX_COORDINATE (a typo
#: such as 1e308 would make the planner's arithmetic overflow).
POSE_FIELDS = Vector(_TextNumber(Float(0.0, "metres or quaternion", min=-MAX_COORDINATE, max=MAX_COORDINATE)),
                     _NAMES, named=True)


@dataclass(frozen=True)
class PoseFile:
    """The goals in driving order and the station pose, if the file gave one."""

    goals: tuple[Pose2D, ...]
    station: Pose2D | None = None
    source: Path | None = None


def _parse_pose(text: str, at: Place) -> Pose2D:
    fields = [f.strip() for f in text.split(",")]
    if len(fields) != len(_NAMES):
        raise at.fail(f"expected 7 comma-separated numbers ({', '.join(_NAMES)}), got {len(fields)}", text)
    x, y, _z, qx, qy, qz, qw = POSE_FIELDS.read(fields, at)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if norm < 1e-9:
        raise at.fail("the orientation quaternion is zero", text)
    return Pose2D(x, y, yaw_from_quaternion(qx / norm, qy / norm, qz / norm, qw / norm))


def parse_poses(text: str, path: Path | str = "<poses>") -> PoseFile:
    """Parse the text of a pose file; ``path`` only names the file in error messages. Each line is read
    against :data:`POSE_FIELDS`, and errors name it as ``goals[i]`` or ``station_pose`` with its line;
    more goals than ``OBJREC_MAX_POSES`` allows are refused before any is parsed."""
    path = Path(path)
    contents = [(n, c) for n, c in enumerate((line.split("#", 1)[0].strip() for line in text.splitlines()), 1) if c]
    goal_lines = [(n, c) for n, c in contents if not c.lower().startswith(STATION_KEY)]
    try:
        check(path, POSES, len(goal_lines), "goal poses")  # before any is parsed
    except InputError as exc:
        raise document_error(exc) from None
    station_lines = [(n, c[len(STATION_KEY):].strip()) for n, c in contents if c.lower().startswith(STATION_KEY)]
    lines = {("goals", i): n for i, (n, _c) in enumerate(goal_lines)}
    if station_lines:
        lines[("station_pose",)] = station_lines[0][0]
    root = Document(path, None, lines).root
    if len(station_lines) > 1:
        second = Document(path, None, {("station_pose",): station_lines[1][0]}).root.key("station_pose")
        raise second.fail(f"a second station_pose (the first is on line {station_lines[0][0]})")
    station = None
    if station_lines and station_lines[0][1]:
        station = _parse_pose(station_lines[0][1], root.key("station_pose"))
    goals = [_parse_pose(content, root.key("goals").item(i)) for i, (_n, content) in enumerate(goal_lines)]
    if not goals:
        raise root.fail("no goal poses (one 'x, y, z, qx, qy, qz, qw' per line expected)")
    return PoseFile(tuple(goals), station, path)


def load_poses(path: str | Path) -> PoseFile:
    """Read a goal-pose file; raises :class:`DocumentError` naming file, line, pose and value on bad input."""
    path = Path(path)
    try:
        text = read_text(path, POSE_FILE_LIMIT)
    except InputError as exc:
        raise document_error(exc, "pose") from None
    return parse_poses(text, path)


def format_pose(pose: Pose2D) -> str:
    """One line of a pose file. Values are made plain floats first: the repr of a NumPy number
    (``np.float64(1.5)``) is no number to :func:`load_poses` or to the ROS patrol."""
    qx, qy, qz, qw = quaternion_from_yaw(float(pose.yaw))
    return ", ".join(repr(round(float(v), 10)) for v in (pose.x, pose.y, 0.0, qx, qy, qz, qw))


def save_poses(path: str | Path, goals: list[Pose2D] | tuple[Pose2D, ...], station: Pose2D | None = None,
               comment: str = "") -> Path:
    """Write goals (and the station) in the ROS patrol's format, so files made here load in the C++/ROS patrol too."""
    path = Path(path)
    lines = [f"# {c}" for c in comment.splitlines()] if comment else []
    lines += ["# x, y, z, qx, qy, qz, qw", f"{STATION_KEY} {format_pose(station)}" if station else STATION_KEY, ""]
    lines += [format_pose(g) for g in goals]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
