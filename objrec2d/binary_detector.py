"""BinaryDetector: every blob of non-zero pixels with a plausible outline length is an object."""

from __future__ import annotations

import cv2
import numpy as np

from objrec_core import Float, Ordered

from .base import ImageDetector, as_gray
from .messages import DetectedObject2D, Polygon


class BinaryDetector(ImageDetector):
    """External contours of the non-zero pixels; each whose length (perimeter in pixels) lies within the
    bounds becomes an object outlined by its convex hull. Given a colour image it converts it to grey once."""

    # The sliders stop at 5000 px (a 640x480 frame's border is 2240 px); a typed value may reach 20000 for big
    # frames. Both share one range, so the two sliders line up and the minimum can follow the maximum.
    min_contour_length = Float(
        40.0, "Shortest outline kept, in pixels; drops specks", min=0.0, max=20000.0, soft_max=5000.0, step=1.0
    )
    max_contour_length = Float(
        5000.0, "Longest outline kept, in pixels; drops the whole-image blob", min=0.0, max=20000.0, soft_max=5000.0,
        step=1.0,
    )
    length_order = Ordered("min_contour_length", "max_contour_length", why="nothing could ever be found")

    def detect(self, frame: np.ndarray) -> list[DetectedObject2D]:
        p = self.params
        lo, hi = p.min_contour_length, p.max_contour_length
        contours, _ = cv2.findContours(as_gray(frame), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        name = self.object_name
        found = []
        for contour in contours:
            if lo <= cv2.arcLength(contour, True) <= hi:
                hull = cv2.convexHull(contour)
                found.append(DetectedObject2D(name, Polygon.from_xy(hull.reshape(-1, 2))))
        return found
