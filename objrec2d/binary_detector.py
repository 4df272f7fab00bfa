"""BinaryDetector: every blob of non-zero pixels with a plausible outline length is an object."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import cv2
import numpy as np

from objrec_core import Float, ParameterError

from .base import ImageDetector, as_gray
from .messages import DetectedObject2D, Polygon


class BinaryDetector(ImageDetector):
    """External contours of the non-zero pixels; each whose length (perimeter in pixels) lies within the
    bounds becomes an object outlined by its convex hull. Given a colour image it converts it to grey once."""

    min_contour_length = Float(40.0, "Shortest outline kept, in pixels; drops specks", min=0.0, max=20000.0, step=1.0)
    max_contour_length = Float(
        5000.0, "Longest outline kept, in pixels; drops the whole-image blob", min=0.0, max=20000.0, step=1.0
    )

    def check_values(self, values: Mapping[str, Any]) -> None:
        if values["min_contour_length"] > values["max_contour_length"]:
            raise ParameterError(
                self.label,
                "min_contour_length",
                values["min_contour_length"],
                f"above max_contour_length {values['max_contour_length']:g}: nothing could ever be found",
            )

    def detect(self, frame: np.ndarray) -> list[DetectedObject2D]:
        p = self.params
        lo, hi = p["min_contour_length"], p["max_contour_length"]
        contours, _ = cv2.findContours(as_gray(frame), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        name = self.object_name
        found = []
        for contour in contours:
            if lo <= cv2.arcLength(contour, True) <= hi:
                hull = cv2.convexHull(contour)
                found.append(DetectedObject2D(name, Polygon.from_xy(hull.reshape(-1, 2))))
        return found
