"""The labels drawn in the GUI's label mode: per frame, the boxes and polygons a person marked and named.

The store is the label mode's document: it knows which frames are labelled, keeps the frames themselves (so the
quality strip scores them without reading the source again), says whether it holds unsaved labels, and turns
itself into the kind's ``TruthSet`` (and back) so that saving and opening go through ``Kind.write_truth`` /
``Kind.read_truth``: one label format, the one objrec-eval reads.

A frame is keyed by its header stamp when it has one (a bag, a live topic: the stamp survives windowing the
recording) and by its index in the source otherwise (an image, a folder, a video, the demo). The first frame
labelled, or the file opened, decides for the whole set.

Every edit is an undo step on the window's undo stack (:class:`LabelStep`, marked ``labels_only`` so that the
parameters are not called modified by it).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QUndoCommand

from objrec_core import Frame, Kind, get_kind
from objrec_core.evaluation.truth import FrameTruth, KeyedBy, TruthSet

#: A box: left, top, width, height in image pixels.
Box = tuple[float, float, float, float]
#: A polygon's corners in image pixels.
Points = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Label:
    """One marked object: a name and either a box or a polygon (a polygon's box is its bounding box); the
    group of a label read from a file is kept (COCO's supercategory: a detection named like it matches)."""

    name: str
    box: Box | None = None
    polygon: Points = ()
    group: str = ""

    @property
    def bounds(self) -> Box:
        if self.polygon:
            xs, ys = [p[0] for p in self.polygon], [p[1] for p in self.polygon]
            return (min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))
        assert self.box is not None
        return self.box

    def contains(self, x: float, y: float) -> bool:
        """Whether the point (image pixels) is on this label: inside its polygon, or its box."""
        if not self.polygon:
            left, top, width, height = self.bounds
            return left <= x <= left + width and top <= y <= top + height
        inside = False
        points = self.polygon
        for (x1, y1), (x2, y2) in zip(points, points[1:] + points[:1], strict=True):
            if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
                inside = not inside
        return inside


def truth_object_type(kind: Kind) -> Callable[..., Any]:
    """What makes the truth objects of a picture kind: ``kind.truth_object`` (NoGroundTruth where it has none).
    The window names no kind package: the kind builds its own objects."""
    return kind.truth_object


def to_truth_object(label: Label, make: Callable[..., Any]) -> Any:
    """The kind's truth object for ``label`` (``make``: from :func:`truth_object_type`)."""
    if label.polygon:
        return make(label.name, polygon=tuple(label.polygon), group=label.group)
    return make(label.name, box=label.box, group=label.group)


def from_truth_object(obj: Any) -> Label:
    """A label for a truth object read from a file: its polygon where it has one, else its box."""
    points = tuple((float(x), float(y)) for x, y in (getattr(obj, "polygon", None) or ()))
    box = None if points else getattr(obj, "box", None)
    corners = tuple(float(v) for v in box) if box is not None else None
    return Label(str(obj.name), corners, points, str(getattr(obj, "group", "") or ""))  # type: ignore[arg-type]


class LabelStore(QObject):
    """The labels of each frame (key: index or stamp, see the module docstring) and the frames themselves.

    ``changed`` is emitted after every edit, undo, redo and open."""

    changed = Signal()

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.keyed_by: KeyedBy | None = None
        self._labels: dict[int, tuple[Label, ...]] = {}
        #: The labelled frames seen on screen (or loaded for the quality strip), by key.
        self.frames: dict[int, Frame] = {}
        #: The truth set's source file, where it was opened from or saved to.
        self.path: str | None = None
        self._saved: dict[int, tuple[Label, ...]] = {}
        #: Counts the label files opened: an undo step made before the last one refers to labels gone.
        self.epoch = 0

    # -- keys -------------------------------------------------------------------------------------------
    def key_of(self, frame: Frame) -> int | None:
        """The key of ``frame`` in this set (None: a stamp-keyed set and a frame without a stamp)."""
        keyed_by = self.keyed_by or ("stamp" if frame.stamp_ns is not None else "index")
        return frame.stamp_ns if keyed_by == "stamp" else frame.index

    def remember(self, frame: Frame) -> int | None:
        """Note ``frame`` as the one labels are drawn on: its key, and the frame kept if labelled."""
        key = self.key_of(frame)
        if key is not None and key in self._labels:
            self.frames[key] = frame
        return key

    # -- content ----------------------------------------------------------------------------------------
    def labels(self, key: int | None) -> tuple[Label, ...]:
        return self._labels.get(key, ()) if key is not None else ()

    def set_labels(self, key: int, labels: Iterable[Label], frame: Frame | None = None) -> None:
        """Replace the labels of one frame (an undo step does this; an empty list keeps the frame labelled
        as "nothing here")."""
        if self.keyed_by is None and frame is not None:
            self.keyed_by = "stamp" if frame.stamp_ns is not None else "index"
        self._labels[key] = tuple(labels)
        if frame is not None:
            self.frames[key] = frame
        self.changed.emit()

    def forget_frame(self, key: int) -> None:
        """The frame is not labelled any more (undoing its first label)."""
        self._labels.pop(key, None)
        self.frames.pop(key, None)
        if not self._labels and not self._saved:
            self.keyed_by = None
        self.changed.emit()

    @property
    def keys(self) -> list[int]:
        return sorted(self._labels)

    @property
    def names(self) -> list[str]:
        """Every name used so far, sorted."""
        return sorted({label.name for labels in self._labels.values() for label in labels})

    def __len__(self) -> int:
        return len(self._labels)

    @property
    def modified(self) -> bool:
        """Whether the labels differ from those last opened or saved."""
        return self._labels != self._saved

    def mark_saved(self, path: str | None) -> None:
        self._saved = dict(self._labels)
        self.path = path
        self.changed.emit()

    # -- truth sets -------------------------------------------------------------------------------------
    def to_truth(self, kind: str) -> TruthSet:
        """Every label as a truth set of the kind called ``kind``."""
        keyed_by = self.keyed_by or "index"
        make = truth_object_type(get_kind(kind))
        frames = []
        for key in self.keys:
            frame = self.frames.get(key)
            index = key if keyed_by == "index" else (frame.index if frame is not None else None)
            stamp = key if keyed_by == "stamp" else (frame.stamp_ns if frame is not None else None)
            frames.append(FrameTruth(index, stamp, tuple(to_truth_object(label, make) for label in self._labels[key])))
        return TruthSet(kind, frames, keyed_by, self.path)

    def load_truth(self, truth: TruthSet) -> None:
        """Replace every label with those of ``truth`` (a file opened): nothing unsaved afterwards."""
        self.epoch += 1
        self.keyed_by = truth.keyed_by
        self._labels = {}
        self.frames = {}
        for frame in truth:
            key = frame.stamp_ns if truth.keyed_by == "stamp" else frame.index
            if key is not None:
                self._labels[key] = tuple(from_truth_object(obj) for obj in frame.objects)
        self.mark_saved(truth.path)


class LabelStep(QUndoCommand):
    """One label edit (add, delete, rename) of one frame, as an undo step on the window's stack."""

    #: Read by the window's change tracker: a label edit leaves the parameters unmodified.
    labels_only = True

    def __init__(self, store: LabelStore, key: int, before: tuple[Label, ...] | None, after: tuple[Label, ...],
                 text: str, frame: Frame | None = None) -> None:
        super().__init__(text)
        self.store, self.key, self.before, self.after, self.frame = store, key, before, after, frame
        self.epoch = store.epoch

    def _stale(self) -> bool:
        """Made before a label file was opened: its labels are gone, so it does nothing (and Qt drops it)."""
        if self.store.epoch != self.epoch:
            self.setObsolete(True)
            return True
        return False

    def redo(self) -> None:
        if not self._stale():
            self.store.set_labels(self.key, self.after, self.frame)

    def undo(self) -> None:
        if self._stale():
            return
        if self.before is None:
            self.store.forget_frame(self.key)
        else:
            self.store.set_labels(self.key, self.before, self.frame)
