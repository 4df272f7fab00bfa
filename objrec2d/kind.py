"""The ``2d`` data kind (entry point ``objrec.kinds``): images as OpenCV arrays, objects as polygons."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from objrec_core import DetectedObjectArray, Frame, FrameKindError, Kind, Outline

from .annotate import draw_objects
from .base import as_bgr
from .messages import DetectedObject2DArray

if TYPE_CHECKING:  # pragma: no cover
    from objrec_core.evaluation import FrameTruth, Scorer, TruthSet


class ImageKind(Kind):
    """Frames are ``uint8`` images, H x W (a mask) or H x W x 1/3/4 (BGR, BGRA); filters may return masks."""

    name = "2d"
    title = "images"
    object_array_type = DetectedObject2DArray

    def check_frame(self, data: Any) -> None:
        if not isinstance(data, np.ndarray):
            raise FrameKindError(f"expected an image (a NumPy array), got {type(data).__name__}")
        if data.ndim not in (2, 3) or (data.ndim == 3 and data.shape[2] not in (1, 3, 4)) or 0 in data.shape:
            raise FrameKindError(f"expected an image (H x W or H x W x 1/3/4), got an array of shape {data.shape}")

    def preview(self, data: Any) -> np.ndarray:
        self.check_frame(data)
        if data.dtype == np.bool_:
            data = data.astype(np.uint8) * 255
        return np.ascontiguousarray(as_bgr(data if data.dtype == np.uint8 else np.clip(data, 0, 255).astype(np.uint8)))

    def annotate(self, frame: Frame, objects: DetectedObjectArray) -> np.ndarray:
        return draw_objects(frame.data, objects.objects)

    def outlines(self, objects: DetectedObjectArray) -> list[Outline]:
        return [Outline(o.name, polygon=np.asarray(o.polygon.xy(), dtype=np.float32).reshape(-1, 2))
                for o in objects.objects]

    def from_rgbd(self, color: Any, depth: Any, fx: float, fy: float, cx: float, cy: float) -> np.ndarray:
        """The colour image (a copy): image pipelines need nothing else of an RGB-D frame.

        Not part of the ``Kind`` contract: this makes the kind an ``objrec_apps.inspection.TakesRGBD``, which
        the inspection patrol checks for (structurally, so this package does not import the app)."""
        self.check_frame(color)
        return np.array(color, dtype=np.uint8, copy=True)

    def copy_frame(self, data: Any) -> Any:
        return data.copy() if isinstance(data, np.ndarray) else super().copy_frame(data)

    # -- ground truth and scoring: COCO JSON label files (objrec2d.truth), box IoU (objrec2d.evaluation) ----
    truth_format = "COCO JSON (.json)"

    def read_truth(self, path: str | os.PathLike[str]) -> TruthSet:
        from .truth import read_coco

        return read_coco(path)

    def write_truth(self, path: str | os.PathLike[str], truth: TruthSet) -> None:
        from .truth import write_coco

        write_coco(path, truth)

    def frame_truth(self, frame: Frame) -> FrameTruth | None:
        """The demo's truth (its shapes and poster, ``Frame.truth``) as truth objects; None for other frames."""
        from .truth import truth_from_demo

        known = frame.truth
        if not isinstance(known, dict) or "objects" not in known:
            return None
        return truth_from_demo(known, frame.index, frame.stamp_ns)

    def truth_object(self, name: str, **geometry: Any) -> Any:
        """A :class:`~objrec2d.truth.TruthObject2D`: ``polygon`` points or a ``box`` (x, y, w, h), ``group``."""
        from .truth import TruthObject2D

        return TruthObject2D(name, **geometry)

    def scorer(self, **options: Any) -> Scorer:
        """An :class:`objrec2d.evaluation.ImageScorer`; options ``iou`` (0.5), ``names`` (scored names),
        ``worst`` (frames whose pictures are kept)."""
        from .evaluation import ImageScorer

        return ImageScorer(**options)
