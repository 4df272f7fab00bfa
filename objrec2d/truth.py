"""2D ground truth: labelled objects (polygons and/or boxes) in COCO JSON, the format every labelling tool
exports and every COCO tool reads.

One label file is one COCO ``instances`` document::

    {"images":      [{"id": 0, "frame_index": 0, "file_name": "frame_000000.png", "width": 640, "height": 480}],
     "categories":  [{"id": 1, "name": "red", "supercategory": "coloured_object"}],
     "annotations": [{"id": 1, "image_id": 0, "category_id": 1, "bbox": [34.0, 82.0, 76.0, 76.0],
                      "segmentation": [[x0, y0, x1, y1, ...]], "area": 4530.1, "iscrowd": 0}]}

- A category's ``name`` is the object name; its optional ``supercategory`` is the object's *group*: a
  detection named like the group matches it too (the colour demo names every find ``coloured_object``).
- An ``images`` entry names its frame in one of three ways, the same for every entry of a file:
  ``frame_index`` (the frame's index in the source, from 0), ``stamp_ns`` (the frame's header stamp in
  nanoseconds: a bag's frames keep it however the recording is cut), or neither, when ``id`` is the frame
  index (a file from a labelling tool whose image ids count the frames of a folder or video from 0).
  An image with no annotation says "nothing here": every detection on it is a false positive.
- An annotation has a ``bbox`` ``[x, y, width, height]`` in pixels (x, y the top-left corner: COCO's
  convention) and/or ``segmentation`` polygons (flat ``[x0, y0, x1, y1, ...]`` lists, 3 points or more);
  one of them at least. Scoring uses the box (the polygons' bounds where no box is given). Crowd regions
  (``iscrowd: 1``) and RLE masks are refused: objrec neither writes nor scores them.
- Other keys (``info``, ``licenses``, a tool's own ``attributes``) are allowed and ignored, so files from
  CVAT, Label Studio or FiftyOne read as they are.

Reading is strict (:func:`read_coco`): a size cap, no duplicate keys, no NaN, and every refusal is one line
naming the file, the JSON path of the field and its value. Writing (:func:`write_coco`) is atomic.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from declare.fields import Document, DocumentError, Field, Invalid, ListOf, Place, Record, Value
from declare.parameters import Float, Int, Str
from objrec_core.evaluation import FrameTruth, TruthSet
from strictio import InputError, read_text, write_atomically

#: The largest label file read: a COCO file of ten thousand frames with polygons is some 50 MB.
MAX_TRUTH_BYTES = 256 * 1024 * 1024
#: How deep a label file may nest (COCO needs 4: document, list, entry, polygon list).
MAX_DEPTH = 32

Point = tuple[float, float]
Outline = tuple[Point, ...]


class TruthFileError(DocumentError):
    """A 2D label file refused: ``FILE: annotations[3].bbox[2]: -5.0 is invalid: RULE``."""


@dataclass(frozen=True)
class TruthObject2D:
    """One labelled object of a frame: its name, its outline (``polygon``, pixel vertices) and/or its box
    (``x, y, width, height``, top-left corner), its group (COCO's supercategory: a detection named like the
    group matches it too) and the ``parts`` of an object seen in pieces (further polygons, COCO allows them).

    Scoring compares boxes (COCO's bbox evaluation): :attr:`bbox` is the box when given, else the bounds of
    the polygons.
    """

    name: str
    polygon: Outline = ()
    box: tuple[float, float, float, float] | None = None
    group: str = ""
    parts: tuple[Outline, ...] = ()

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("a truth object needs a name")
        if self.box is None and len(self.polygon) < 3:
            raise ValueError(f"truth object {self.name!r} needs a box or a polygon of 3 points or more")

    @property
    def outlines(self) -> tuple[Outline, ...]:
        """Every polygon of the object (its outline, then its parts)."""
        return tuple(p for p in (self.polygon, *self.parts) if p)

    @property
    def bbox(self) -> tuple[float, float, float, float]:
        """``x, y, width, height``: the box, or the bounds of the polygons."""
        if self.box is not None:
            return self.box
        return polygon_bbox([p for outline in self.outlines for p in outline])

    @property
    def area(self) -> float:
        """The polygons' area (as COCO stores it), the box's where there is no polygon."""
        if self.outlines:
            return sum(polygon_area(outline) for outline in self.outlines)
        _x, _y, w, h = self.bbox
        return w * h

    def matches(self, detected_name: str) -> bool:
        """Whether a detection of this name may be this object (its name, or its group)."""
        return detected_name == self.name or (bool(self.group) and detected_name == self.group)


def polygon_bbox(points: Sequence[Sequence[float]]) -> tuple[float, float, float, float]:
    """``x, y, width, height`` of the points' bounds (all zero for no points)."""
    if not points:
        return (0.0, 0.0, 0.0, 0.0)
    xs = [float(p[0]) for p in points]
    ys = [float(p[1]) for p in points]
    return (min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))


def polygon_area(points: Sequence[Sequence[float]]) -> float:
    """The shoelace area of a closed polygon."""
    total = 0.0
    for i in range(len(points)):
        x0, y0 = points[i - 1]
        x1, y1 = points[i]
        total += x0 * y1 - x1 * y0
    return abs(total) / 2.0


# -- reading ---------------------------------------------------------------------------------------------
class _Polygons(Field):
    """COCO ``segmentation``: a list of flat ``[x0, y0, x1, y1, ...]`` polygons (RLE masks refused)."""

    def convert(self, value: Any, at: Place) -> tuple[Outline, ...]:
        if isinstance(value, Mapping):
            raise Invalid("an RLE mask: objrec reads polygons only (flat [x0, y0, x1, y1, ...] lists)")
        if not isinstance(value, list):
            raise Invalid(f"expected a list of polygons, got {type(value).__name__}")
        outlines = []
        for i, flat in enumerate(value):
            here = at.item(i)
            if not isinstance(flat, list) or len(flat) < 6 or len(flat) % 2:
                raise here.fail("expected a flat list [x0, y0, x1, y1, ...] of 3 points or more (an even count of "
                                "6 numbers or more)", flat)
            numbers = [_COORD.read(v, here.item(j)) for j, v in enumerate(flat)]
            outlines.append(tuple(zip(numbers[0::2], numbers[1::2], strict=True)))
        return tuple(outlines)

    def describe(self) -> str:
        return "a list of polygons"


class _Box(Field):
    """COCO ``bbox``: ``[x, y, width, height]``, finite, width and height not negative."""

    def convert(self, value: Any, at: Place) -> tuple[float, float, float, float]:
        if not isinstance(value, list) or len(value) != 4:
            raise Invalid("expected [x, y, width, height]")
        x, y = (_COORD.read(v, at.item(i)) for i, v in enumerate(value[:2]))
        w, h = (_SIZE.read(v, at.item(i + 2)) for i, v in enumerate(value[2:]))
        return (x, y, w, h)


_COORD = Value(Float(0.0, "a pixel coordinate"))
_SIZE = Value(Float(0.0, "a size in pixels", min=0.0))
_ID = Value(Int(0, "an id"), required=True)
_NAME = Value(Str("", "the object name"), required=True, check=lambda s: None if s.strip() else "must not be empty")

_IMAGE = Record({
    "id": _ID,
    "frame_index": Value(Int(None, "the frame's index in its source", min=0, optional=True)),
    "stamp_ns": Value(Int(None, "the frame's header stamp, nanoseconds", optional=True)),
    "file_name": Value(Str(None, "the frame's file", optional=True)),
    "width": Value(Int(None, "width in pixels", min=1, optional=True)),
    "height": Value(Int(None, "height in pixels", min=1, optional=True)),
}, ignore_unknown=True)
_CATEGORY = Record({
    "id": _ID,
    "name": _NAME,
    "supercategory": Value(Str("", "the group a detection may be named by", optional=True)),
}, ignore_unknown=True)
_ANNOTATION = Record({
    "id": Value(Int(None, "the annotation's id", optional=True)),
    "image_id": _ID,
    "category_id": _ID,
    "bbox": _Box(),
    "segmentation": _Polygons(default=()),
    "iscrowd": Value(Int(0, "crowd region (not supported)", optional=True),
                     check=lambda v: "crowd regions are not supported: label each object" if v else None),
}, ignore_unknown=True)
_DOCUMENT = Record({
    "images": ListOf(_IMAGE, required=True),
    "categories": ListOf(_CATEGORY, required=True),
    "annotations": ListOf(_ANNOTATION, required=True),
}, ignore_unknown=True)


def read_coco(path: str | os.PathLike[str]) -> TruthSet:
    """The 2D truth of a COCO JSON label file; a :class:`TruthFileError` (an InputError: one line, exit 2)
    naming file, JSON path and value for anything refused."""
    data = _parse_json(path)
    document = Document(Path(path), data, {}, error=TruthFileError)
    root = document.root
    if not isinstance(data, dict):
        raise root.fail(f"expected a COCO document (a JSON object with images, categories and annotations), got "
                        f"{_json_type(data)}")
    fields = _DOCUMENT.read(data, root)
    images_at, categories_at, annotations_at = root.key("images"), root.key("categories"), root.key("annotations")

    categories: dict[int, tuple[str, str]] = {}
    names: dict[str, int] = {}
    for i, category in enumerate(fields["categories"]):
        at = categories_at.item(i)
        if category["id"] in categories:
            raise at.key("id").fail("a second category with this id", category["id"])
        name = category["name"]
        if name in names:
            raise at.key("name").fail(f"a second category of this name (ids {names[name]} and {category['id']})",
                                      name)
        categories[category["id"]] = (name, category["supercategory"] or "")
        names[name] = category["id"]

    keyed_by, frames = _frames(fields["images"], images_at)
    objects: dict[int, list[TruthObject2D]] = {image_id: [] for image_id in frames}
    for i, annotation in enumerate(fields["annotations"]):
        at = annotations_at.item(i)
        image_id, category_id = annotation["image_id"], annotation["category_id"]
        if image_id not in frames:
            raise at.key("image_id").fail("no image has this id", image_id)
        if category_id not in categories:
            raise at.key("category_id").fail("no category has this id", category_id)
        outlines = annotation["segmentation"]
        box = annotation["bbox"]
        if box is None and not outlines:
            raise at.fail("an annotation needs a bbox or a segmentation polygon")
        if box is not None and outlines and box == polygon_bbox([p for outline in outlines for p in outline]):
            box = None  # the polygons' own bounds, as COCO files (and write_coco) repeat them
        name, group = categories[category_id]
        objects[image_id].append(TruthObject2D(name, outlines[0] if outlines else (), box, group,
                                               tuple(outlines[1:])))
    truth = [FrameTruth(index, stamp, tuple(objects[image_id])) for image_id, (index, stamp) in frames.items()]
    truth.sort(key=lambda f: (f.index if f.index is not None else -1, f.stamp_ns or 0))
    return TruthSet("2d", truth, keyed_by, str(path))


def _frames(images: Iterable[dict[str, Any]], at: Place) -> tuple[str, dict[int, tuple[int | None, int | None]]]:
    """How the file keys its frames, and each image id's (index, stamp)."""
    frames: dict[int, tuple[int | None, int | None]] = {}
    seen: dict[int, int] = {}
    mode = ""
    for i, image in enumerate(images):
        here = at.item(i)
        this = "frame_index" if image["frame_index"] is not None else \
            "stamp_ns" if image["stamp_ns"] is not None else "id"
        mode = mode or this
        if this != mode:
            raise here.fail(f"names its frame by {this} where the first image names it by {mode}: every image of "
                            "a file names its frame the same way (frame_index, stamp_ns, or id as the index)")
        if image["id"] in frames:
            raise here.key("id").fail("a second image with this id", image["id"])
        key = image[mode]
        if mode == "id" and key < 0:
            raise here.key("id").fail("a frame index (the image names its frame by id) must be 0 or more", key)
        if key in seen:
            raise here.key(mode).fail(f"images[{seen[key]}] labels the same frame", key)
        seen[key] = i
        frames[image["id"]] = (None, key) if mode == "stamp_ns" else (key, image["stamp_ns"])
    return ("stamp" if mode == "stamp_ns" else "index"), frames


def _parse_json(path: str | os.PathLike[str]) -> Any:
    """The JSON value of a file, refusing duplicate keys, NaN and infinities, numbers too big to hold, deep
    nesting and more than :data:`MAX_TRUTH_BYTES`."""
    try:
        text = read_text(path, MAX_TRUTH_BYTES)
    except InputError as exc:  # not a file, too big, not UTF-8: the same error family as a bad field
        raise TruthFileError(exc.path, exc.where, exc.message) from None

    def unique(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in pairs:
            if key in out:
                raise _Refused(f"duplicate key {json.dumps(key)[:60]} in one object")
            out[key] = value
        return out

    def constant(name: str) -> Any:
        raise _Refused(f"{name} is not a number JSON allows")

    def real(text: str) -> float:
        value = float(text)
        if not math.isfinite(value):
            raise _Refused(f"{text[:40]} is too large a number")
        return value

    try:
        data = json.loads(text, object_pairs_hook=unique, parse_constant=constant, parse_float=real)
    except json.JSONDecodeError as exc:
        raise TruthFileError(path, "", f"not valid JSON: {exc.msg}", line=exc.lineno) from None
    except _Refused as exc:
        raise TruthFileError(path, "", f"not valid JSON: {exc}") from None
    except RecursionError:
        raise TruthFileError(path, "", "not valid JSON: nested too deeply") from None
    except ValueError as exc:  # an integer of more digits than Python converts
        raise TruthFileError(path, "", f"not valid JSON: {str(exc).split(';')[0]}") from None
    if _depth(data) > MAX_DEPTH:
        raise TruthFileError(path, "", f"nested deeper than {MAX_DEPTH} levels")
    return data


class _Refused(ValueError):
    pass


def _depth(value: Any) -> int:
    stack = [(value, 1)]
    deepest = 0
    while stack:
        item, level = stack.pop()
        deepest = max(deepest, level)
        if isinstance(item, dict):
            stack.extend((v, level + 1) for v in item.values())
        elif isinstance(item, list):
            stack.extend((v, level + 1) for v in item)
    return deepest


def _json_type(value: Any) -> str:
    return {dict: "an object", list: "a list", str: "text", bool: "true or false", type(None): "null"}.get(
        type(value), "a number")


# -- writing ---------------------------------------------------------------------------------------------
def coco_document(truth: TruthSet, image_size: tuple[int, int] | None = None) -> dict[str, Any]:
    """``truth`` as a COCO document (what :func:`write_coco` saves): images in frame order, ids from 0 (the
    frame index where the set is keyed by index), categories by name from id 1, annotations from id 1."""
    groups: dict[str, str] = {}
    for frame in truth.frames:
        for obj in frame.objects:
            if groups.setdefault(obj.name, obj.group) != obj.group:
                raise ValueError(f"object name {obj.name!r} has two groups, {groups[obj.name]!r} and {obj.group!r}: "
                                 "COCO gives each category one supercategory")
    category_ids = {name: i + 1 for i, name in enumerate(sorted(groups))}
    images, annotations = [], []
    for number, frame in enumerate(truth.frames):
        image: dict[str, Any]
        if truth.keyed_by == "stamp":
            if frame.stamp_ns is None:
                raise ValueError(f"frame {number} of a set keyed by stamp has no stamp")
            image = {"id": number, "stamp_ns": frame.stamp_ns, "file_name": f"frame_{number:06d}.png"}
        else:
            if frame.index is None:
                raise ValueError(f"frame {number} of a set keyed by index has no index")
            image = {"id": frame.index, "frame_index": frame.index, "file_name": f"frame_{frame.index:06d}.png"}
            if frame.stamp_ns is not None:
                image["stamp_ns"] = frame.stamp_ns
        if image_size is not None:
            image["width"], image["height"] = image_size
        images.append(image)
        for obj in frame.objects:
            annotation: dict[str, Any] = {
                "id": len(annotations) + 1, "image_id": image["id"], "category_id": category_ids[obj.name],
                "bbox": [float(v) for v in obj.bbox], "area": float(obj.area), "iscrowd": 0,
                "segmentation": [[float(c) for point in outline for c in point] for outline in obj.outlines],
            }
            annotations.append(annotation)
    categories = [{"id": i, "name": name, "supercategory": groups[name]} for name, i in category_ids.items()]
    return {"info": {"description": "objrec ground truth", "keyed_by": truth.keyed_by},
            "images": images, "categories": categories, "annotations": annotations}


def write_coco(path: str | os.PathLike[str], truth: TruthSet, image_size: tuple[int, int] | None = None) -> None:
    """Save ``truth`` as COCO JSON, atomically (the old file, if any, stays until the new one is whole);
    ``image_size`` (width, height) fills the images' sizes where known."""
    text = json.dumps(coco_document(truth, image_size), indent=1)
    write_atomically(path, text + "\n")


def truth_from_demo(truth: Mapping[str, Any], index: int | None, stamp_ns: int | None = None) -> FrameTruth:
    """A 2D demo frame's own truth (``Frame.truth``: the shapes it drew and its poster) as truth objects: each
    shape by its colour name in the group ``coloured_object`` (what the colour demo system reports), the
    poster by its name in the group ``poster`` (what the feature demo system reports)."""
    objects = [TruthObject2D(str(o["name"]), tuple((float(x), float(y)) for x, y in o["polygon"]),
                             group="coloured_object") for o in truth.get("objects", ())]
    target = truth.get("target")
    if target is not None:
        objects.append(TruthObject2D(str(target["name"]), tuple((float(x), float(y)) for x, y in target["corners"]),
                                     group="poster"))
    return FrameTruth(index, stamp_ns, tuple(objects))


__all__ = ["MAX_TRUTH_BYTES", "TruthFileError", "TruthObject2D", "coco_document", "polygon_area", "polygon_bbox",
           "read_coco", "truth_from_demo", "write_coco"]
