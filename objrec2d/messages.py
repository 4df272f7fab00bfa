"""2D detected-object messages, field for field as the seed's ``object_detection_2d_msgs``."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from objrec_core import DetectedObjectArray


@dataclass(frozen=True)
class Point32:
    """``geometry_msgs/Point32``: a polygon vertex in image pixels; z is always 0 for images."""

    x: float
    y: float
    z: float = 0.0


@dataclass(frozen=True)
class Polygon:
    """``geometry_msgs/Polygon``."""

    points: tuple[Point32, ...] = ()

    @classmethod
    def from_xy(cls, xy: Iterable[Iterable[float]]) -> Polygon:
        return cls(tuple(Point32(float(x), float(y)) for x, y in xy))

    def xy(self) -> list[tuple[float, float]]:
        return [(p.x, p.y) for p in self.points]

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
        return {
            "name": self.name,
            "polygon": {"points": [{"x": p.x, "y": p.y, "z": p.z} for p in self.polygon.points]},
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DetectedObject2D:
        points = data.get("polygon", {}).get("points", [])
        return cls(
            str(data.get("name", "")),
            Polygon(tuple(Point32(float(p["x"]), float(p["y"]), float(p.get("z", 0.0))) for p in points)),
        )


@dataclass
class DetectedObject2DArray(DetectedObjectArray):
    """All objects found in one image (``object_detection_2d_msgs/DetectedObject2DArray``)."""

    object_type = DetectedObject2D
