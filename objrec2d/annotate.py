"""Draw detected objects on an image, for people who would rather look than read."""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np

from strictio.shown import drawable

from .base import as_bgr
from .messages import DetectedObject2D

PALETTE = [(0, 255, 255), (255, 0, 255), (0, 255, 0), (255, 128, 0), (0, 128, 255), (255, 255, 0)]


def draw_objects(image: np.ndarray, objects: Iterable[DetectedObject2D], thickness: int = 2) -> np.ndarray:
    """A copy of ``image`` (colour) with each object's polygon and name drawn on it."""
    canvas = as_bgr(image).copy()
    colours: dict[str, tuple[int, int, int]] = {}
    for obj in objects:
        pts = np.array(obj.polygon.xy(), dtype=np.float32)
        if len(pts) == 0:
            continue
        colour = colours.setdefault(obj.name, PALETTE[len(colours) % len(PALETTE)])
        cv2.polylines(canvas, [np.round(pts).astype(np.int32)], True, colour, thickness, cv2.LINE_AA)
        x, y = pts.min(axis=0)
        cv2.putText(
            canvas, drawable(obj.name), (int(x), max(12, int(y) - 5)), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1,
            cv2.LINE_AA,
        )
    return canvas
