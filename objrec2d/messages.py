"""2D detected-object messages, field for field as the ROS ``object_detection_2d_msgs``."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from objrec_core import DetectedObjectArray


@dataclass(frozen=True, slots=True)
class Point32:
    """``geometry_msgs/Point32``: a polygon vertex in image pixels; z is always 0 for images."""

    x: float
    y: float
    z: float = 0.0


class Polygon:
    """``geometry_msgs/Polygon``.

    Detectors hand over their vertex array; it becomes a list only when someone reads the vertices, and
    the ``Point32`` objects only when someone reads ``points``, which keeps a detector's hot path as cheap as
    the bare OpenCV calls (a list made per object cost 0.1 ms per frame on a frame of 70 blobs).
    """

    __slots__ = ("_points", "_xy")

    def __init__(self, points: Iterable[Point32] = ()) -> None:
        self._points: tuple[Point32, ...] | None = tuple(points)
        self._xy: Any = None  # the vertices as handed over: a list of pairs, or an N x 2 array

    @classmethod
    def from_xy(cls, xy: Iterable[Iterable[float]]) -> Polygon:
        """From vertices ``[[x, y], ...]`` (a list, or an array of N x 2 or N x 1 x 2 such as
        ``cv2.convexHull``'s, which the polygon then owns: the caller must not change it)."""
        polygon = cls.__new__(cls)
        polygon._points = None
        polygon._xy = xy if hasattr(xy, "tolist") else [list(v) for v in xy]
        return polygon

    def _rows(self) -> list[Any]:
        """The handed-over vertices as a list of pairs, converted from an array once, on first read."""
        if hasattr(self._xy, "tolist"):
            self._xy = self._xy.reshape(-1, 2).tolist()
        return self._xy or []

    @property
    def points(self) -> tuple[Point32, ...]:
        if self._points is None:
            self._points = tuple(Point32(float(x), float(y)) for x, y in self._rows())
        return self._points

    def xy(self) -> list[tuple[float, float]]:
        if self._points is None:
            return [(float(x), float(y)) for x, y in self._rows()]
        return [(p.x, p.y) for p in self._points]

    def to_dict(self) -> dict[str, Any]:
        if self._points is None:
            return {"points": [{"x": float(x), "y": float(y), "z": 0.0} for x, y in self._rows()]}
        return {"points": [{"x": p.x, "y": p.y, "z": p.z} for p in self._points]}

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Polygon) and self.points == other.points

    def __hash__(self) -> int:
        return hash(self.points)

    def __repr__(self) -> str:
        return f"Polygon({self.xy()!r})"

    def __len__(self) -> int:
        return len(self._points) if self._points is not None else len(self._rows())

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


@dataclass(frozen=True, slots=True)
class DetectedObject2D:
    """One object found in an image: its name and outline.

    ``truncated``: the object touches the image border, so the frame cuts it off and the outline is only its
    visible part (its centre and size are not the object's). A JSON line carries the key only where it is true,
    so lines of whole objects read as before; the typed ROS message always has the field (false by default).

    Slotted: a busy frame makes 70 of these, and an instance without a ``__dict__`` is made and freed in less
    time (benchmarks/bench_2d.py). Nothing may add attributes to one; it pickles through its fields.
    """

    name: str
    polygon: Polygon = field(default_factory=Polygon)
    truncated: bool = False

    @classmethod
    def outlined(cls, name: str, outlines: Iterable[Any], truncated: Iterable[bool]) -> list[DetectedObject2D]:
        """``[DetectedObject2D(name, Polygon.from_xy(xy), t) for xy, t in zip(outlines, truncated)]`` at a third
        of its cost, for a detector that makes one object per blob (70 on a busy frame, where the frozen
        constructor's ``object.__setattr__`` per field was most of the framework's overhead against bare
        OpenCV): each object is filled as an unfrozen twin of the same layout and then becomes a
        ``DetectedObject2D``. Each outline (an N x 2 or N x 1 x 2 array such as ``cv2.convexHull``'s, or a list
        of pairs) is owned by its polygon afterwards, as in ``Polygon.from_xy``."""
        if cls is not DetectedObject2D:  # a subclass may have another layout: its own constructor
            return [cls(name, Polygon.from_xy(xy), flag) for xy, flag in zip(outlines, truncated, strict=True)]
        objects = []
        keep = objects.append
        new_polygon, unfrozen, array = _new_polygon, _Unfrozen, np.ndarray
        for xy, flag in zip(outlines, truncated, strict=True):
            polygon = new_polygon(Polygon)
            polygon._points = None
            polygon._xy = xy if type(xy) is array or hasattr(xy, "tolist") else [list(v) for v in xy]
            obj = unfrozen()
            obj.name = name
            obj.polygon = polygon
            obj.truncated = flag
            obj.__class__ = cls
            keep(obj)
        return objects

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {"name": self.name, "polygon": self.polygon.to_dict()}
        if self.truncated:
            data["truncated"] = True
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DetectedObject2D:
        points = data.get("polygon", {}).get("points", [])
        return cls(
            str(data.get("name", "")),
            Polygon(tuple(Point32(float(p["x"]), float(p["y"]), float(p.get("z", 0.0))) for p in points)),
            bool(data.get("truncated", False)),
        )


_new_polygon = object.__new__


class _Unfrozen:
    """``DetectedObject2D``'s slots without its frozen guard: filled with three plain stores and then made a
    ``DetectedObject2D`` by ``__class__`` (the layouts are the same, so Python allows it)."""

    __slots__ = DetectedObject2D.__slots__


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
        "object_detection_2d_msgs/msg/DetectedObject2D": "string name\ngeometry_msgs/Polygon polygon\nbool truncated\n",
    }
