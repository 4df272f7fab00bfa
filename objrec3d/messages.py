"""3D detected-object messages, field for field as the ROS ``object_detection_3d_msgs`` (listing 5.2).

A ``DetectedObject3D`` has a ``name`` and a ``box`` (``OrientedBox``: ``pose`` with ``position`` and
``orientation``, then ``width``, ``height``, ``depth``). ``shape``, ``radius``, ``inliers`` and ``id`` are
extra fields a ROS consumer may ignore.

Box frame: the box's local x axis spans ``width``, y spans ``height``, z spans ``depth``; ``orientation``
rotates those local axes into the sensor frame. For a cylinder the local y axis is the cylinder axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from objrec_core import DetectedObjectArray


@dataclass(frozen=True)
class Point:
    """``geometry_msgs/Point`` (metres)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])


@dataclass(frozen=True)
class Quaternion:
    """``geometry_msgs/Quaternion``, a unit quaternion (x, y, z, w); the identity by default."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0

    @classmethod
    def from_matrix(cls, rotation: Any) -> Quaternion:
        """From a 3 x 3 rotation matrix (Shepperd's method), normalised, with w >= 0."""
        m = np.asarray(rotation, dtype=np.float64)
        trace = m[0, 0] + m[1, 1] + m[2, 2]
        if trace > 0:
            s = math.sqrt(trace + 1.0) * 2
            q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
        elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
            s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
            q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
        elif m[1, 1] > m[2, 2]:
            s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
            q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
        else:
            s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
            q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
        v = np.array(q)
        v /= np.linalg.norm(v)
        if v[3] < 0:
            v = -v
        return cls(*(float(c) for c in v))

    def as_matrix(self) -> np.ndarray:
        """The 3 x 3 rotation matrix (its columns are the box's local x, y, z axes in the sensor frame)."""
        x, y, z, w = self.x, self.y, self.z, self.w
        n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
        x, y, z, w = x / n, y / n, z / n, w / n
        return np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ])


@dataclass(frozen=True)
class Pose:
    """``geometry_msgs/Pose``."""

    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass(frozen=True)
class OrientedBox:
    """``object_detection_3d_msgs/OrientedBox``: the pose of the box centre and its three side lengths."""

    pose: Pose = field(default_factory=Pose)
    width: float = 0.0
    height: float = 0.0
    depth: float = 0.0

    def corners(self) -> np.ndarray:
        """The eight corners in the sensor frame (8 x 3), for drawing."""
        half = np.array([self.width, self.height, self.depth]) / 2.0
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
        rotation = self.pose.orientation.as_matrix()
        return (signs * half) @ rotation.T + self.pose.position.as_array()


@dataclass(frozen=True)
class DetectedObject3D:
    """One object found in a point cloud: its name and oriented box, plus what the shape fit found.

    ``shape`` is "sphere" or "cylinder" (empty for other detectors), ``radius`` in metres and ``inliers``
    the number of points that support the fit. ``id`` names the object across the frames of a stream: an
    object that stays keeps it (see ``objrec3d.tracking``); empty when nothing tracks the objects. Like
    ``vision_msgs/Detection3D.id`` it is a string, so a consumer compares it and never computes with it.
    """

    name: str
    box: OrientedBox = field(default_factory=OrientedBox)
    shape: str = ""
    radius: float = 0.0
    inliers: int = 0
    id: str = ""

    @property
    def center(self) -> np.ndarray:
        return self.box.pose.position.as_array()

    @property
    def axis(self) -> np.ndarray:
        """The box's height axis in the sensor frame: a cylinder's axis (see docs/3d.md for its sign)."""
        return self.box.pose.orientation.as_matrix()[:, 1]

    def to_dict(self) -> dict[str, Any]:
        p, q = self.box.pose.position, self.box.pose.orientation
        data: dict[str, Any] = {
            "name": self.name,
            "id": self.id,
            "box": {
                "pose": {
                    "position": {"x": p.x, "y": p.y, "z": p.z},
                    "orientation": {"x": q.x, "y": q.y, "z": q.z, "w": q.w},
                },
                "width": self.box.width,
                "height": self.box.height,
                "depth": self.box.depth,
            },
        }
        if self.shape:
            data.update(shape=self.shape, radius=self.radius, inliers=self.inliers)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DetectedObject3D:
        box = data.get("box", {})
        pose = box.get("pose", {})
        p, q = pose.get("position", {}), pose.get("orientation", {})
        return cls(
            name=str(data.get("name", "")),
            box=OrientedBox(
                Pose(
                    Point(float(p.get("x", 0.0)), float(p.get("y", 0.0)), float(p.get("z", 0.0))),
                    Quaternion(float(q.get("x", 0.0)), float(q.get("y", 0.0)), float(q.get("z", 0.0)),
                               float(q.get("w", 1.0))),
                ),
                float(box.get("width", 0.0)),
                float(box.get("height", 0.0)),
                float(box.get("depth", 0.0)),
            ),
            shape=str(data.get("shape", "")),
            radius=float(data.get("radius", 0.0)),
            inliers=int(data.get("inliers", 0)),
            id=str(data.get("id", "")),
        )


@dataclass
class DetectedObject3DArray(DetectedObjectArray):
    """All objects found in one cloud (``object_detection_3d_msgs/DetectedObject3DArray``).

    ``ros_type`` and ``ros_definitions`` (ROS ``.msg`` text per type) let a kind-agnostic writer publish
    these arrays as typed ROS messages: the definitions are embedded in the bags and MCAP files it writes.
    A ROS message has no optional fields: an object without a shape fit carries ``shape: ""``,
    ``radius: 0.0`` and ``inliers: 0`` there, where its JSON line leaves them out. ``id`` is in both always
    (empty when untracked), so JSON and typed messages list the same identities.
    """

    object_type = DetectedObject3D
    ros_type: ClassVar[str] = "object_detection_3d_msgs/msg/DetectedObject3DArray"
    ros_definitions: ClassVar[dict[str, str]] = {
        "object_detection_3d_msgs/msg/DetectedObject3DArray": "std_msgs/Header header\nDetectedObject3D[] objects\n",
        "object_detection_3d_msgs/msg/DetectedObject3D": (
            "string name\nOrientedBox box\nstring shape\nfloat64 radius\nuint32 inliers\nstring id\n"
        ),
        "object_detection_3d_msgs/msg/OrientedBox": (
            "geometry_msgs/Pose pose\nfloat64 width\nfloat64 height\nfloat64 depth\n"
        ),
    }
