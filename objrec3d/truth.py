"""3D ground truth: the shapes of some frames of one source, in a YAML label file.

A person (or the renderer that made the frames) says, for some frames, which shapes are there: a sphere, an
upright or lying cylinder, a box. Each is given in the frame of the cloud (the camera frame for the demo and
the RGB-D sources: x right, y down, z forward, metres), the frame the 3D detectors report in. Example::

    format: objrec-truth-3d
    version: 1
    keyed_by: index               # or stamp: frames carry stamp_ns (a bag's header stamps) instead of index
    frames:
      - index: 0
        objects:
          - {name: cylinder, shape: cylinder, centre: [-0.12, 0.31, 0.93], radius: 0.04, height: 0.12,
             axis: [0.0, -0.74, -0.67]}
          - {name: sphere, shape: sphere, centre: [0.14, 0.29, 0.96], radius: 0.06}
          - {name: crate, shape: box, centre: [0.3, 0.25, 1.1], size: [0.2, 0.1, 0.15],
             orientation: [0.0, 0.0, 0.0, 1.0]}
      - index: 5
        objects: []               # labelled: nothing here (every detection on it is a false positive)

The fields of one object (:data:`SHAPE_FIELDS` is the table the reader checks, :func:`schema_rows` the same
table in words):

- ``name`` (required): the object's name, what a detector's ``object_name`` reports.
- ``shape`` (required): ``sphere``, ``cylinder`` or ``box``.
- ``centre`` (required): ``[x, y, z]`` metres, the middle of the solid.
- ``radius``: sphere and cylinder, metres (> 0).
- ``axis``: cylinder, a direction ``[x, y, z]`` (normalised on reading; its sign does not matter).
- ``height``: cylinder, the length along the axis, metres (> 0).
- ``size``: box, ``[width, height, depth]`` along the box's local x, y, z (as ``OrientedBox``), metres.
- ``orientation``: box, a quaternion ``[x, y, z, w]`` turning the local axes into the cloud's frame
  (default: the identity; normalised on reading).
- ``id``: optional, the object's identity across frames where two objects share a name (tracking figures
  follow ``id``, else ``name``).
- ``visible_points``: optional, how many of the frame's points show the object (a renderer knows); used for
  "recall against visible points" when the scorer has no cloud to count them in.

A field that does not belong to the shape is refused, so a typo never passes silently. Every refusal is one
line: ``FILE:LINE: frames[3].objects[1].radius: VALUE is invalid: RULE``. The writer saves atomically and
writes floats exactly (``repr``), so a file read and written again is the same file.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from declare import Choice, Float, Int, Str
from declare.fields import (
    Document,
    DocumentError,
    Free,
    Invalid,
    ListOf,
    Place,
    Record,
    Value,
    Vector,
    document_from_text,
    not_blank,
    read_document,
)
from objrec_core.evaluation import FrameTruth, TruthSet
from strictio import YAMLLimits, write_atomically

#: The ``format`` value of a 3D label file.
FORMAT = "objrec-truth-3d"
VERSION = 1
SHAPES = ("sphere", "cylinder", "box")
#: The fields each shape has besides name, shape, centre, id and visible_points.
SHAPE_SIZE_FIELDS: dict[str, tuple[str, ...]] = {
    "sphere": ("radius",),
    "cylinder": ("radius", "axis", "height"),
    "box": ("size", "orientation"),
}
#: A coordinate or size beyond this (metres) is a typo, not a scene.
MAX_METRES = 1.0e4
#: A label file of thousands of frames is a few megabytes; this is a cap, never a bomb.
TRUTH_YAML_LIMITS = YAMLLimits(max_bytes=256 * 1024 * 1024, max_depth=10)

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class TruthShape:
    """One labelled shape in the cloud's frame (metres).

    ``axis`` is a cylinder's unit axis (None otherwise); ``size`` a box's ``(width, height, depth)`` along its
    local x, y, z and ``orientation`` the unit quaternion ``(x, y, z, w)`` turning them into the cloud's frame.
    ``id`` names the object across frames (empty: the ``name`` does); ``visible_points`` is how many points of
    the frame show it, where the maker of the file knew (None: unknown).
    """

    name: str
    shape: str
    centre: Vec3
    radius: float = 0.0
    axis: Vec3 | None = None
    height: float = 0.0
    size: Vec3 | None = None
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    id: str = ""
    visible_points: int | None = None

    @property
    def identity(self) -> str:
        """Who this object is across frames: its ``id``, else its name."""
        return self.id or self.name

    @property
    def scale(self) -> float:
        """The object's own size for tolerances: the radius of a sphere or cylinder, half a box's smallest side."""
        if self.shape == "box" and self.size is not None:
            return 0.5 * min(self.size)
        return self.radius

    def rotation(self) -> np.ndarray:
        """A box's 3 x 3 rotation (columns: its local axes in the cloud's frame); the identity otherwise."""
        from .messages import Quaternion

        return Quaternion(*self.orientation).as_matrix()

    def to_dict(self) -> dict[str, Any]:
        """The object as the label file writes it: only the fields of its shape."""
        data: dict[str, Any] = {"name": self.name, "shape": self.shape, "centre": list(self.centre)}
        if self.shape in ("sphere", "cylinder"):
            data["radius"] = self.radius
        if self.shape == "cylinder":
            data["height"] = self.height
            data["axis"] = list(self.axis or (0.0, 0.0, 1.0))
        if self.shape == "box":
            data["size"] = list(self.size or (0.0, 0.0, 0.0))
            data["orientation"] = list(self.orientation)
        if self.id:
            data["id"] = self.id
        if self.visible_points is not None:
            data["visible_points"] = self.visible_points
        return data


def _floats(values: Iterable[Any]) -> Any:
    return tuple(float(v) for v in values)


def _unit(values: Sequence[float], what: str) -> Any:
    norm = math.sqrt(sum(v * v for v in values))
    if not (norm > 1e-9 and math.isfinite(norm)):
        raise Invalid(f"{what} must not be zero")
    if abs(norm - 1.0) < 1e-12:  # already a unit vector: kept bit for bit, so a file reads back the same
        return tuple(float(v) for v in values)
    return tuple(float(v) / norm for v in values)


_COORDINATE = Float(0.0, "metres in the cloud's frame", min=-MAX_METRES, max=MAX_METRES)
_LENGTH = Float(0.1, "metres", min=0.0, min_open=True, max=MAX_METRES)
_COMPONENT = Float(0.0, "a component", min=-MAX_METRES, max=MAX_METRES)


def _shape_fields(shape: str) -> dict[str, Any]:
    """The table of one object of ``shape``."""
    fields: dict[str, Any] = {
        "name": Value(Str("", "the object's name (a detector's object_name)"), required=True, check=not_blank),
        "shape": Value(Choice("sphere", SHAPES, "sphere, cylinder or box"), required=True),
        "centre": Vector(_COORDINATE, ("x", "y", "z"), required=True, doc="the middle of the solid, metres"),
        "id": Str("", "the object's identity across frames (default: its name)"),
        "visible_points": Value(Int(0, "points of the frame that show the object", min=0, optional=True),
                                default=None),
    }
    if shape in ("sphere", "cylinder"):
        fields["radius"] = Value(_LENGTH, required=True, doc="the radius, metres")
    if shape == "cylinder":
        fields["height"] = Value(_LENGTH, required=True, doc="the length along the axis, metres")
        fields["axis"] = Vector(_COMPONENT, ("x", "y", "z"), required=True,
                                doc="the axis direction [x, y, z] (normalised on reading; either sign)",
                                check=lambda v: None if any(v) else "the axis must not be zero")
    if shape == "box":
        fields["size"] = Vector(_LENGTH, ("width", "height", "depth"), required=True,
                                doc="the sides along the box's local x, y, z, metres")
        fields["orientation"] = Vector(_COMPONENT, ("x", "y", "z", "w"), default=(0.0, 0.0, 0.0, 1.0),
                                       doc="a quaternion [x, y, z, w] turning the box's local axes into the "
                                           "cloud's frame (default: the identity)",
                                       check=lambda v: None if any(v) else "the quaternion must not be zero")
    return fields


#: One table per shape: what :func:`read_truth` checks every object against.
SHAPE_FIELDS: dict[str, Record] = {shape: Record(_shape_fields(shape)) for shape in SHAPES}


class _ShapeEntry(Free):
    """One entry of a frame's ``objects``: its ``shape`` chooses its table."""

    def __init__(self) -> None:
        super().__init__(required=True)

    def convert(self, value: Any, at: Place) -> TruthShape:
        if not isinstance(value, dict):
            raise Invalid(f"expected a mapping of a shape's fields, got {type(value).__name__}")
        if "shape" not in value:
            raise at.key("shape").fail(f"missing (one of {', '.join(SHAPES)})")
        shape = Value(Choice(SHAPES[0], SHAPES)).read(value["shape"], at.key("shape"))
        raw = SHAPE_FIELDS[shape].read(value, at)
        kept = {"radius": raw.get("radius", 0.0), "height": raw.get("height", 0.0)}
        axis = _unit(raw["axis"], "the axis") if shape == "cylinder" else None
        size = _floats(raw["size"]) if shape == "box" else None
        orientation = _unit(raw["orientation"], "the quaternion") if shape == "box" else (0.0, 0.0, 0.0, 1.0)
        return TruthShape(raw["name"], shape, _floats(raw["centre"]), axis=axis, size=size, orientation=orientation,
                          id=raw["id"], visible_points=raw["visible_points"], **kept)

    def describe(self) -> str:
        return "a shape: a mapping of name, shape, centre, ..."


_FRAME_FIELDS = Record({
    "index": Value(Int(0, "the frame's index in its source", min=0, optional=True), default=None),
    "stamp_ns": Value(Int(0, "the frame's header stamp, nanoseconds", min=0, optional=True), default=None),
    "objects": ListOf(_ShapeEntry(), null_is_empty=True, doc="the shapes in the frame"),
})

#: What a 3D label file holds.
TRUTH_FIELDS = Record({
    "format": Value(Choice(FORMAT, (FORMAT,), "what the file is"), required=True),
    "version": Value(Int(VERSION, "the format's version", min=VERSION, max=VERSION), required=True),
    "keyed_by": Choice("index", ("index", "stamp"), "how frames are found: by index or by header stamp"),
    "frames": ListOf(Record(_FRAME_FIELDS.fields), null_is_empty=True, doc="the labelled frames"),
})


def _truth_set(document: Document) -> TruthSet:
    at = document.root
    raw = TRUTH_FIELDS.read(document.data, at)
    keyed_by = raw["keyed_by"]
    key = "index" if keyed_by == "index" else "stamp_ns"
    seen: dict[int, int] = {}
    frames = []
    for i, entry in enumerate(raw["frames"]):
        here = at.key("frames").item(i)
        value = entry[key]
        if value is None:
            raise here.key(key).fail(f"missing (the file is keyed by {keyed_by})")
        if value in seen:
            raise here.key(key).fail(f"frames[{seen[value]}] has it already", value)
        seen[value] = i
        frames.append(FrameTruth(entry["index"], entry["stamp_ns"], tuple(entry["objects"])))
    path = None if document.path is None else str(document.path)
    return TruthSet("3d", frames, keyed_by, path)


def read_truth(path: str | os.PathLike[str]) -> TruthSet:
    """The 3D label file at ``path``; a :class:`DocumentError` (one line: file, line, field, value, rule)."""
    return _truth_set(read_document(path, TRUTH_YAML_LIMITS, "label"))


def parse_truth(text: str, path: str | os.PathLike[str] = "<truth>") -> TruthSet:
    """A 3D label file's text (``path`` names it in errors)."""
    return _truth_set(document_from_text(text, path, TRUTH_YAML_LIMITS))


def truth_text(truth: TruthSet) -> str:
    """The label file of ``truth``: one line per object, floats exact."""
    import yaml

    lines = [f"format: {FORMAT}", f"version: {VERSION}", f"keyed_by: {truth.keyed_by}"]
    if not truth.frames:
        lines.append("frames: []")
        return "\n".join(lines) + "\n"
    lines.append("frames:")
    for frame in truth.frames:
        keys = {"index": frame.index, "stamp_ns": frame.stamp_ns}
        first = True
        for name in ("index", "stamp_ns"):
            if keys[name] is not None:
                lines.append(f"  {'- ' if first else '  '}{name}: {int(keys[name])}")
                first = False
        if first:
            raise ValueError("a frame's truth needs an index or a stamp_ns")
        if not frame.objects:
            lines.append("    objects: []")
            continue
        lines.append("    objects:")
        for obj in frame.objects:
            text = yaml.safe_dump(as_truth_shape(obj).to_dict(), default_flow_style=True, sort_keys=False,
                                  width=1 << 30, allow_unicode=True).strip()
            lines.append(f"      - {text}")
    return "\n".join(lines) + "\n"


def write_truth(path: str | os.PathLike[str], truth: TruthSet) -> None:
    """Save ``truth`` as a 3D label file, atomically (complete or not at all)."""
    write_atomically(path, truth_text(truth))


def as_truth_shape(obj: Any) -> TruthShape:
    """A truth object as a :class:`TruthShape` (itself, or the plain dict a renderer wrote in the same layout)."""
    if isinstance(obj, TruthShape):
        return obj
    if isinstance(obj, dict):
        return _ShapeEntry().read(obj, Document(None).root)
    raise TypeError(f"expected a TruthShape or a dict of its fields, got {type(obj).__name__}")


def demo_truth_shapes(truth: Any) -> tuple[TruthShape, ...]:
    """The shapes of a demo frame's ``Frame.truth`` (``objrec3d.demo.DemoTruth``) as truth shapes, each named
    by its shape ("cylinder", "sphere"), as the demo's parameter file names its detectors."""
    shapes = []
    for s in getattr(truth, "shapes", ()):
        centre = _floats(np.asarray(s.center, dtype=float))
        if s.shape == "cylinder" and s.axis is not None:
            axis = _unit(_floats(np.asarray(s.axis, dtype=float)), "the axis")
            shapes.append(TruthShape(s.shape, "cylinder", centre, float(s.radius), axis, float(s.height)))
        else:
            shapes.append(TruthShape(s.shape, s.shape, centre, float(s.radius)))
    return tuple(shapes)


def schema_rows() -> list[tuple[str, str, str]]:
    """The label file's object fields in words: (field, shapes, what), from the tables themselves."""
    rows: dict[str, tuple[list[str], str]] = {}
    for shape, record in SHAPE_FIELDS.items():
        for name, field in record.fields.items():
            what = field.doc or field.describe()
            if field.required:
                what += " (required)"
            rows.setdefault(name, ([], what))[0].append(shape)
    return [(name, ", ".join(shapes) if len(shapes) < len(SHAPES) else "all", what)
            for name, (shapes, what) in rows.items()]


__all__ = ["FORMAT", "SHAPES", "SHAPE_FIELDS", "TRUTH_FIELDS", "DocumentError", "TruthShape",
           "as_truth_shape", "demo_truth_shapes", "parse_truth", "read_truth", "schema_rows", "truth_text",
           "write_truth"]
