"""WhiteBalanceFilter: undoes a colour cast before colour thresholds see the image.

Fixed HSV ranges assume white light. Under a cool (bluish) or warm (orange) light the grey of a floor or a
wall gets a hue and enough saturation to pass a saturation threshold: with the camera on its tungsten preset in
daylight, the shipped colour system (params/hsv_demo.yaml) finds 10 of the 40 objects of 10 demo scenes and
3,957 false blue ones in their grey background; under a 2,500 K bulb with a daylight preset the whole frame
passes and is dropped as background: 0 found (scripts/measure_white_balance.py). A camera's automatic
white balance would undo that, but robot cameras often run with it off (fixed exposure for repeatable colours)
or it follows the scene slowly. This filter estimates the light's colour from the frame itself and divides it
out, channel by channel:

- ``gray_world``: the average of the scene is grey, so each channel is scaled to the mean of the three
  channel means. Good where no single colour dominates the picture.
- ``white_patch``: the brightest pixels are white (a highlight, paper, a white wall), so each channel is
  scaled so that its ``white_percentile`` reaches the same level. Good where large coloured objects would
  pull the gray-world average; wrong where the white is clipped (255 in the channel the light boosts).

``max_gain`` bounds how far any channel is amplified (a frame of one strong colour has no grey to find).
"""

from __future__ import annotations

from typing import ClassVar

import cv2
import numpy as np

from objrec_core import Choice, Float

from .base import ImageFilter, as_bgr


class WhiteBalanceFilter(ImageFilter):
    """Per-channel gains that make the scene's estimated light white (gray world or white patch)."""

    METHODS: ClassVar[tuple[str, ...]] = ("gray_world", "white_patch")

    method = Choice(
        "gray_world", METHODS,
        "gray_world: the scene's average is grey; white_patch: its brightest pixels are white",
    )
    white_percentile = Float(
        99.0, "white_patch: the brightness percentile of each channel taken as white (below 100 ignores "
        "specks and clipped highlights)", min=50.0, max=100.0, step=0.5, relevant={"method": ("white_patch",)},
    )
    max_gain = Float(
        4.0, "Largest factor any channel is scaled by; bounds the correction of a frame without grey or white",
        min=1.0, max=16.0, step=0.5,
    )

    def filter(self, frame: np.ndarray) -> np.ndarray:
        """The frame with the cast removed (BGR ``uint8``); a mask or grey image passes through unchanged."""
        if frame.ndim == 2 or (frame.ndim == 3 and frame.shape[2] == 1):
            return frame
        image = as_bgr(frame)
        gains = self.gains(image)
        return cv2.transform(image, np.diag(gains).astype(np.float32))

    def gains(self, image: np.ndarray) -> np.ndarray:
        """The factors for B, G and R this frame gets (the mean gain is about 1, so brightness stays)."""
        p = self.params
        if p.method == "gray_world":
            # Every pixel counts, clipped ones too: leaving out pixels clipped in one channel left out the whole
            # white table of smarties.png under a cool light, and the candies alone then set the gains.
            levels = np.array(cv2.mean(image)[:3])
        else:
            levels = np.array([_percentile(image, channel, p.white_percentile) for channel in range(3)])
        levels = np.maximum(levels, 1.0)
        gains = levels.mean() / levels
        return np.clip(gains, 1.0 / p.max_gain, p.max_gain)


def _percentile(image: np.ndarray, channel: int, percentile: float) -> float:
    """The level below which ``percentile`` % of the channel's pixels lie, from its histogram (a sort of a
    VGA frame's 307,200 values per channel costs ten times more)."""
    histogram = cv2.calcHist([image], [channel], None, [256], [0, 256]).ravel()
    cumulative = np.cumsum(histogram)
    return float(np.searchsorted(cumulative, cumulative[-1] * percentile / 100.0))
