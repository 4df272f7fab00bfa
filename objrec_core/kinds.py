"""The data-kind contract: everything kind-specific that the framework and the apps need, in one object.

A data kind (images, point clouds, or a third party's own, such as 1-D signals) is one :class:`Kind`
subclass registered under the ``objrec.kinds`` entry-point group. The storage checks a file's ``kind``
against the registered kinds, the apps open sources, check frames, draw annotations and previews through it,
and the GUI asks it for the geometry of detected objects: none of them names a kind or imports its package.
"""

from __future__ import annotations

import copy
import os
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from .messages import DetectedObjectArray
from .sources import Frame

if TYPE_CHECKING:  # pragma: no cover
    from .evaluation import FrameTruth, Scorer, TruthSet


class NoGroundTruth(LookupError):
    """A kind that reads no label files or scores no detections (a plug-in kind that did not implement it)."""


class FrameKindError(TypeError):
    """Data that is not a frame of the kind asked for (an image given to a point-cloud pipeline)."""


@dataclass(frozen=True)
class Outline:
    """How a view draws one detected object.

    ``polygon`` is N x 2 pixel coordinates in the frame's preview (image kinds); ``box`` is the 8 x 3 corners
    of an oriented box in the frame's coordinates, corner ``i`` at ``-/+`` half a side along the box's local
    x, y and z axes by bits 2, 1 and 0 of ``i``. A kind fills the one its views use.
    """

    label: str
    polygon: Any = None
    box: Any = None


class Kind(ABC):
    """One data kind. Subclasses set the class attributes and implement the abstract methods.

    Methods take a frame's data (what ``Frame.data`` and every filter's output hold), never a Qt or an
    OpenCV type, and pictures are NumPy arrays: H x W x 3, ``uint8``, BGR.
    """

    #: The registered name, written as ``kind:`` in parameter files ("2d", "3d").
    name: ClassVar[str]
    #: What a person calls this data, for menus and messages ("images", "point clouds").
    title: ClassVar[str]
    #: The message type detectors of this kind report.
    object_array_type: ClassVar[type[DetectedObjectArray]] = DetectedObjectArray
    #: The source that shows this kind with no hardware or files (``demo`` in every built-in kind).
    demo_spec: ClassVar[str] = "demo"
    #: Whether views show this kind's data as 3D points (``points``) rather than as preview pictures.
    has_points: ClassVar[bool] = False

    @abstractmethod
    def check_frame(self, data: Any) -> None:
        """Raise FrameKindError saying what ``data`` is when it is not this kind's frame data."""

    def is_frame(self, data: Any) -> bool:
        try:
            self.check_frame(data)
        except FrameKindError:
            return False
        return True

    @abstractmethod
    def preview(self, data: Any) -> Any:
        """A picture of a frame or of a filter's output (BGR ``uint8`` H x W x 3) for views."""

    @abstractmethod
    def annotate(self, frame: Frame, objects: DetectedObjectArray) -> Any:
        """The frame with its detected objects drawn, as a BGR picture (``--annotate``, the GUI)."""

    def outlines(self, objects: DetectedObjectArray) -> list[Outline]:
        """The geometry of each detected object for views that draw it themselves."""
        return [Outline(str(getattr(o, "name", "object"))) for o in objects.objects]

    def points(self, data: Any) -> Any:
        """N x 3 float points of a frame for 3D views (kinds with ``has_points``); None otherwise."""
        return None

    def copy_frame(self, data: Any) -> Any:
        """An independent copy of frame data (to prove a module leaves its input alone)."""
        return copy.deepcopy(data)

    def frames_equal(self, a: Any, b: Any) -> bool:
        """Whether two frames hold the same data (NumPy arrays compared element-wise, NaN equal to NaN)."""
        return _equal(a, b)

    # -- ground truth and scoring (objrec-eval, objrec-tune, the GUI's label mode); optional for a kind ------
    #: The label file's form, for messages and file dialogs ("COCO JSON (.json)").
    truth_format: ClassVar[str] = ""

    def read_truth(self, path: str | os.PathLike[str]) -> TruthSet:
        """The label file at ``path`` in this kind's format; an ``InputError`` naming file, field and value."""
        raise NoGroundTruth(f"the {self.name} kind reads no label files")

    def write_truth(self, path: str | os.PathLike[str], truth: TruthSet) -> None:
        """Save ``truth`` in this kind's label format, atomically (complete or not at all)."""
        raise NoGroundTruth(f"the {self.name} kind writes no label files")

    def frame_truth(self, frame: Frame) -> FrameTruth | None:
        """The truth a source put on ``frame`` (``Frame.truth``: a demo knows what it drew) as this kind's truth
        objects, or None where the source knows none."""
        return None

    def truth_object(self, name: str, **geometry: Any) -> Any:
        """One of this kind's truth objects from its name and the label file's geometry fields (2D: ``polygon``
        points or a ``box`` x, y, w, h, and ``group``): how a labelling tool that names no kind package makes
        the objects it saves."""
        raise NoGroundTruth(f"the {self.name} kind has no truth objects to label with")

    def scorer(self, **options: Any) -> Scorer:
        """A fresh scorer of this kind's detections against its truth objects (options: the kind's own,
        such as an IoU threshold)."""
        raise NoGroundTruth(f"the {self.name} kind scores no detections")

    def __repr__(self) -> str:
        return f"<data kind {self.name!r}: {self.title}>"


def _equal(a: Any, b: Any) -> bool:
    if type(a) is not type(b):
        return False
    shape = getattr(a, "shape", None)
    if shape is not None and hasattr(a, "dtype"):
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind in "fc":
            same = (a == b) | ((a != a) & (b != b))  # NaN equals NaN here
            return bool(same.all())
        return bool((a == b).all())
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    slots = getattr(a, "__dict__", None)
    if slots is not None:
        return _equal(vars(a), vars(b))
    return bool(a == b)
