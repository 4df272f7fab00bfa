"""The ``3d`` data kind (entry point ``objrec.kinds``): point clouds, objects as oriented boxes."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from objrec_core import DetectedObjectArray, Frame, FrameKindError, Kind, Outline
from objrec_core.evaluation import FrameTruth, Scorer, TruthSet

from .cloud import PointCloud
from .messages import DetectedObject3DArray


class CloudKind(Kind):
    """Frames are ``PointCloud``s (organized or not); filters keep them clouds."""

    name = "3d"
    title = "point clouds"
    object_array_type = DetectedObject3DArray
    has_points = True

    def check_frame(self, data: Any) -> None:
        if not isinstance(data, PointCloud):
            raise FrameKindError(f"expected a PointCloud, got {type(data).__name__}")

    def preview(self, data: Any) -> np.ndarray:
        from .annotate import render_cloud

        self.check_frame(data)
        return render_cloud(data)[0]

    def annotate(self, frame: Frame, objects: DetectedObjectArray) -> np.ndarray:
        from .annotate import annotate

        return annotate(frame, objects)

    def outlines(self, objects: DetectedObjectArray) -> list[Outline]:
        found = []
        for obj in objects.objects:
            corners = obj.box.corners()
            label = obj.name if not obj.shape or obj.shape == obj.name else f"{obj.name} ({obj.shape})"
            if np.isfinite(corners).all():
                found.append(Outline(label, box=corners))
        return found

    def points(self, data: Any) -> np.ndarray:
        self.check_frame(data)
        return data.points

    def from_rgbd(self, color: Any, depth: Any, fx: float, fy: float, cx: float, cy: float) -> PointCloud:
        """An organized cloud in the optical frame (x right, y down, z forward), RGB colours, NaN for no return.

        Not part of the ``Kind`` contract: this makes the kind an ``objrec_apps.inspection.TakesRGBD``, which
        the inspection patrol checks for (structurally, so this package does not import the app)."""
        z = np.asarray(depth, dtype=np.float32)
        rgb = np.asarray(color)
        if z.ndim != 2 or rgb.shape[:2] != z.shape or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise FrameKindError(f"expected H x W depth and H x W x 3 colour of the same size, got {z.shape} and "
                                 f"{rgb.shape}")
        h, w = z.shape
        z = np.where(z > 0, z, np.float32(np.nan))  # 0 is "no return" in depth images too
        u = (np.arange(w, dtype=np.float32) - np.float32(cx)) / np.float32(fx)
        v = (np.arange(h, dtype=np.float32) - np.float32(cy)) / np.float32(fy)
        points = np.empty((h, w, 3), np.float32)
        np.multiply(z, u[None, :], out=points[..., 0])
        np.multiply(z, v[:, None], out=points[..., 1])
        points[..., 2] = z
        return PointCloud(points, np.ascontiguousarray(rgb[..., ::-1], dtype=np.uint8), w, h)

    def copy_frame(self, data: Any) -> Any:
        return data.copy() if isinstance(data, PointCloud) else super().copy_frame(data)

    # -- ground truth and scoring: objrec3d.truth (the shapes file) and objrec3d.evaluation -------------------
    truth_format = "3D shapes YAML (.yaml)"

    def read_truth(self, path: str | os.PathLike[str]) -> TruthSet:
        from .truth import read_truth

        return read_truth(path)

    def write_truth(self, path: str | os.PathLike[str], truth: TruthSet) -> None:
        from .truth import write_truth

        write_truth(path, truth)

    def frame_truth(self, frame: Frame) -> FrameTruth | None:
        """The demo's ``DemoTruth`` as truth shapes named by their shape; a source that already gives a
        ``FrameTruth`` or a list of truth shapes (or their dicts) has it taken as it is."""
        from .truth import as_truth_shape, demo_truth_shapes

        truth = frame.truth
        if isinstance(truth, FrameTruth):
            return truth
        if hasattr(truth, "shapes"):
            return FrameTruth(frame.index, frame.stamp_ns, demo_truth_shapes(truth))
        if isinstance(truth, list | tuple):
            return FrameTruth(frame.index, frame.stamp_ns, tuple(as_truth_shape(o) for o in truth))
        return None

    def scorer(self, **options: Any) -> Scorer:
        from .evaluation import ShapeScorer

        return ShapeScorer(**options)

    def frames_equal(self, a: Any, b: Any) -> bool:
        if not (isinstance(a, PointCloud) and isinstance(b, PointCloud)):
            return super().frames_equal(a, b)
        parts = ("points", "colors", "width", "height", "sensor_origin")
        return all(super(CloudKind, self).frames_equal(getattr(a, n), getattr(b, n)) for n in parts)
