"""HSVFilter: keeps the pixels whose hue, saturation and value lie in ranges; returns a mask."""

from __future__ import annotations

import cv2
import numpy as np

from objrec_core import Int

from .base import ImageFilter, as_bgr


class HSVFilter(ImageFilter):
    """Colour thresholding in HSV (OpenCV ranges: hue 0..179, saturation and value 0..255).

    The result is a single-channel mask (255 inside the ranges), not an RGB image: the next stage wants a
    mask, and a conversion to RGB and back would only cost time. When ``h_min > h_max`` the hue range wraps
    around 0, so one filter selects red (e.g. 170..10).
    """

    h_min = Int(0, "Lowest hue kept; above h_max the range wraps around 0 (red)", min=0, max=179)
    h_max = Int(179, "Highest hue kept", min=0, max=179)
    s_min = Int(0, "Lowest saturation kept; raise it to ignore grey and white", min=0, max=255)
    s_max = Int(255, "Highest saturation kept", min=0, max=255)
    v_min = Int(0, "Lowest value (brightness) kept; raise it to ignore shadows", min=0, max=255)
    v_max = Int(255, "Highest value (brightness) kept", min=0, max=255)

    def filter(self, frame: np.ndarray) -> np.ndarray:
        p = self.params
        hsv = cv2.cvtColor(as_bgr(frame), cv2.COLOR_BGR2HSV)
        low_sv, high_sv = (p.s_min, p.v_min), (p.s_max, p.v_max)
        if p.h_min <= p.h_max:
            return cv2.inRange(hsv, (p.h_min, *low_sv), (p.h_max, *high_sv))
        upper = cv2.inRange(hsv, (p.h_min, *low_sv), (179, *high_sv))
        lower = cv2.inRange(hsv, (0, *low_sv), (p.h_max, *high_sv))
        return cv2.bitwise_or(upper, lower, dst=upper)
