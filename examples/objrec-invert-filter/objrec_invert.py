"""An example third-party filter: inverts an image or a mask.

It lives in its own package and reaches objrec through an entry point (see pyproject.toml beside it):
no change to objrec is needed for objrec-define and objrec-detect to offer it. test_objrec_invert.py beside
it shows how a plug-in checks itself against everything its declarations promise (``check_module``).
"""

from __future__ import annotations

import cv2
import numpy as np

from objrec2d import ImageFilter
from objrec_core import Bool, Int


class InvertFilter(ImageFilter):
    """Turns dark into bright: dark objects on a light table become blobs the BinaryDetector can find."""

    threshold = Int(0, "Pixels at or below this become white, the rest black; 0 inverts every pixel", min=0,
                    max=255)
    grey = Bool(True, "Convert colour to grey first, so the result is a mask")

    def filter(self, frame: np.ndarray) -> np.ndarray:
        p = self.params  # one consistent snapshot for the whole frame
        image = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if p.grey and frame.ndim == 3 else frame
        if p.threshold == 0:
            return cv2.bitwise_not(image)
        _, mask = cv2.threshold(image, p.threshold, 255, cv2.THRESH_BINARY_INV)
        return mask
