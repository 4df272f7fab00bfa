"""Bases for point-cloud modules: they set the data kind and the message type."""

from __future__ import annotations

from typing import ClassVar

from objrec_core import DetectedObjectArray, Detector, Filter

from .messages import DetectedObject3DArray


class CloudFilter(Filter):
    """A filter on ``PointCloud``s. Keeps an organized cloud organized (dropped points become NaN)."""

    kind = "3d"


class CloudDetector(Detector):
    """A detector on ``PointCloud``s; reports ``DetectedObject3DArray``."""

    kind = "3d"
    object_array_type: ClassVar[type[DetectedObjectArray]] = DetectedObject3DArray
