"""Draw detected objects on an image, for people who would rather look than read."""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np

from strictio.shown import drawable

from .base import as_bgr
from .messages import DetectedObject2D

PALETTE = [(0, 255, 255), (255, 0, 255), (0, 255, 0), (255, 128, 0), (0, 128, 255), (255, 255, 0)]
FONT = cv2.FONT_HERSHEY_SIMPLEX
FONT_SCALE = 0.5


def label_origin(shape: tuple[int, ...], pts: np.ndarray, label: str) -> tuple[int, int]:
    """Where a name's baseline starts: above the outline's top-left corner, moved inwards so the whole name
    stays in the image (an object at the right edge, often cut by it, would otherwise lose its name's end)."""
    (width, height), _ = cv2.getTextSize(drawable(label), FONT, FONT_SCALE, 1)
    x, y = pts.min(axis=0)
    x = min(int(x), shape[1] - width - 1)
    return max(0, x), min(max(height + 2, int(y) - 5), shape[0] - 2)


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
        origin = label_origin(canvas.shape, pts, obj.name)
        cv2.putText(canvas, drawable(obj.name), origin, FONT, FONT_SCALE, colour, 1, cv2.LINE_AA)
    return canvas
