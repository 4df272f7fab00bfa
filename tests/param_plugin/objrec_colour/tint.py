"""``TintFilter``: blends an image towards a colour; uses the plug-in's ``Colour`` with built-in types."""

from __future__ import annotations

import numpy as np

from objrec2d import ImageFilter
from objrec_core import Float, Int

from .colour import Colour, rgb


class TintFilter(ImageFilter):
    """Moves every pixel ``strength`` of the way towards ``tint``, then caps the levels at ``ceiling``."""

    tint = Colour("#ff8000", "the colour blended in")
    strength = Float(0.5, "share of the tint: above 0 (else the filter does nothing), at most 1", min=0.0,
                     min_open=True, max=1.0, step=0.05)
    ceiling = Int(None, "brightest level kept (none: no cap)", min=1, max=255, optional=True)

    def filter(self, frame: np.ndarray) -> np.ndarray:
        p = self.params
        red, green, blue = rgb(p.tint)
        target = np.array([blue, green, red], np.float32)  # OpenCV images are BGR
        if frame.ndim == 2:
            target = target.mean(keepdims=True)[0]
        out = frame.astype(np.float32) * (1.0 - p.strength) + target * p.strength
        if p.ceiling is not None:
            np.minimum(out, p.ceiling, out=out)
        return np.rint(out).astype(np.uint8)
