"""2D detected-object messages, field for field as the ROS ``object_detection_2d_msgs``."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, ClassVar

from objrec_core import DetectedObjectArray


@dataclass(frozen=True)
class Point32:
    """``geometry_msgs/Point32``: a polygon vertex in image pixels; z is always 0 for images."""

    x: float
    y: float
    z: float = 0.0


class Polygon:
    """``geometry_msgs/Polygon``.

    Detectors hand over their vertex array; the ``Point32`` objects are built only when someone reads
    ``points``, which keeps a detector's hot path as cheap as the bare OpenCV calls.
    """

    __slots__ = ("_points", "_xy")

    def __init__(self, points: Iterable[Point32] = ()) -> None:
        self._points: tuple[Point32, ...] | None = tuple(points)
        self._xy: list[list[float]] | None = None

    @classmethod
    def from_xy(cls, xy: Iterable[Iterable[float]]) -> Polygon:
        """From vertices ``[[x, y], ...]`` (a list, or an N x 2 array such as ``cv2.convexHull``'s)."""
        polygon = cls.__new__(cls)
        polygon._points = None
        polygon._xy = xy.tolist() if hasattr(xy, "tolist") else [list(v) for v in xy]
        return polygon

    @property
    def points(self) -> tuple[Point32, ...]:
        if self._points is None:
            self._points = tuple(Point32(float(x), float(y)) for x, y in self._xy or ())
        return self._points

    def xy(self) -> list[tuple[float, float]]:
        if self._points is None:
            return [(float(x), float(y)) for x, y in self._xy or ()]
        return [(p.x, p.y) for p in self._points]

    def to_dict(self) -> dict[str, Any]:
        if self._points is None:
            return {"points": [{"x": float(x), "y": float(y), "z": 0.0} for x, y in self._xy or ()]}
        return {"points": [{"x": p.x, "y": p.y, "z": p.z} for p in self._points]}

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Polygon) and self.points == other.points

    def __hash__(self) -> int:
        return hash(self.points)

    def __repr__(self) -> str:
        return f"Polygon({self.xy()!r})"

    def __len__(self) -> int:
        return len(self._points) if self._points is not None else len(self._xy or ())

    def area(self) -> float:
        pts = self.xy()
        return 0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True)))

    def centroid(self) -> tuple[float, float]:
        """Area centroid (the vertex mean where the polygon has no area)."""
        pts = self.xy()
        if not pts:
            raise ValueError("an empty polygon has no centroid")
        cross_sum = cx = cy = 0.0
        for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True):
            c = x0 * y1 - x1 * y0
            cross_sum += c
            cx += (x0 + x1) * c
            cy += (y0 + y1) * c
        if abs(cross_sum) < 1e-9:
            return sum(p[0] for p in pts) / len(pts), sum(p[1] for p in pts) / len(pts)
        return cx / (3 * cross_sum), cy / (3 * cross_sum)


@dataclass(frozen=True)
class DetectedObject2D:
    """One object found in an image: its name and outline."""

    name: str
    polygon: Polygon = field(default_factory=Polygon)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "polygon": self.polygon.to_dict()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DetectedObject2D:
        points = data.get("polygon", {}).get("points", [])
        return cls(
            str(data.get("name", "")),
            Polygon(tuple(Point32(float(p["x"]), float(p["y"]), float(p.get("z", 0.0))) for p in points)),
        )


@dataclass
class DetectedObject2DArray(DetectedObjectArray):
    """All objects found in one image (``object_detection_2d_msgs/DetectedObject2DArray``).

    ``ros_type`` and ``ros_definitions`` (ROS ``.msg`` text per type) let a kind-agnostic writer publish
    these arrays as typed ROS messages: the definitions are embedded in the bags and MCAP files it writes.
    """

    object_type = DetectedObject2D
    ros_type: ClassVar[str] = "object_detection_2d_msgs/msg/DetectedObject2DArray"
    ros_definitions: ClassVar[dict[str, str]] = {
        "object_detection_2d_msgs/msg/DetectedObject2DArray": "std_msgs/Header header\nDetectedObject2D[] objects\n",
        "object_detection_2d_msgs/msg/DetectedObject2D": "string name\ngeometry_msgs/Polygon polygon\n",
    }
