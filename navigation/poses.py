"""The goal-pose file: one ``x, y, z, qx, qy, qz, qw`` per line, in driving order.

``#`` starts a comment, blank lines are ignored, and an optional ``station_pose:`` line gives the pose
about one metre in front of the docking station (it may be left empty when there is no station).
Orientations are quaternions because the poses were read off ROS (amcl); only the yaw matters here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from strictio import POSES, InputError, read_text
from strictio.limits import check

from .geometry import Pose2D, quaternion_from_yaw, yaw_from_quaternion
from .maps import MAX_COORDINATE

#: A pose file holds one line per goal: 4 MiB is tens of thousands of goals.
POSE_FILE_LIMIT = 4 * 1024 * 1024

STATION_KEY = "station_pose:"


class PoseFileError(ValueError):
    """A goal-pose file that cannot be used; the message names the file, the line and the text."""


@dataclass(frozen=True)
class PoseFile:
    """The goals in driving order and the station pose, if the file gave one."""

    goals: tuple[Pose2D, ...]
    station: Pose2D | None = None
    source: Path | None = None


def _parse_pose(path: Path, lineno: int, text: str) -> Pose2D:
    fields = [f.strip() for f in text.split(",")]
    if len(fields) != 7:
        raise PoseFileError(
            f"{path}: line {lineno}: expected 7 comma-separated numbers "
            f"(x, y, z, qx, qy, qz, qw), got {len(fields)} in {text!r}")
    values = []
    for name, raw in zip(("x", "y", "z", "qx", "qy", "qz", "qw"), fields, strict=True):
        shown = repr(raw) if len(raw) <= 40 else f"{raw[:30]!r}... ({len(raw):,} characters)"
        try:
            value = float(raw)
        except ValueError:
            raise PoseFileError(f"{path}: line {lineno}: {name} is not a number: {shown}") from None
        if not math.isfinite(value):
            raise PoseFileError(f"{path}: line {lineno}: {name} is not finite: {shown}")
        if abs(value) > MAX_COORDINATE:
            raise PoseFileError(f"{path}: line {lineno}: {name} must lie within ±{MAX_COORDINATE:g}, got {shown}")
        values.append(value)
    x, y, _z, qx, qy, qz, qw = values
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if norm < 1e-9:
        raise PoseFileError(f"{path}: line {lineno}: the orientation quaternion is zero in {text!r}")
    return Pose2D(x, y, yaw_from_quaternion(qx / norm, qy / norm, qz / norm, qw / norm))


def parse_poses(text: str, path: Path | str = "<poses>") -> PoseFile:
    """Parse the text of a pose file; ``path`` only names the file in error messages. Every number must be
    finite and within ±MAX_COORDINATE (a typo such as 1e308 would make the planner's arithmetic overflow);
    more goals than ``OBJREC_MAX_POSES`` allows are refused before any is parsed."""
    path = Path(path)
    contents = [(n, c) for n, c in enumerate((line.split("#", 1)[0].strip() for line in text.splitlines()), 1) if c]
    goal_count = sum(1 for _n, c in contents if not c.lower().startswith(STATION_KEY))
    try:
        check(path, POSES, goal_count, "goal poses")  # before any is parsed
    except InputError as exc:
        raise PoseFileError(str(exc)) from None
    goals: list[Pose2D] = []
    station: Pose2D | None = None
    station_line = 0
    for lineno, content in contents:
        if content.lower().startswith(STATION_KEY):
            if station_line:
                raise PoseFileError(
                    f"{path}: line {lineno}: second station_pose (the first is on line {station_line})")
            station_line = lineno
            rest = content[len(STATION_KEY):].strip()
            if rest:
                station = _parse_pose(path, lineno, rest)
            continue
        goals.append(_parse_pose(path, lineno, content))
    if not goals:
        raise PoseFileError(f"{path}: no goal poses (one 'x, y, z, qx, qy, qz, qw' per line expected)")
    return PoseFile(tuple(goals), station, path)


def load_poses(path: str | Path) -> PoseFile:
    """Read a goal-pose file; raises :class:`PoseFileError` naming file, line and text on bad input."""
    path = Path(path)
    try:
        text = read_text(path, POSE_FILE_LIMIT)
    except InputError as exc:
        if exc.message == "file not found":
            raise PoseFileError(f"{path}: pose file not found") from None
        raise PoseFileError(str(exc)) from None
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
