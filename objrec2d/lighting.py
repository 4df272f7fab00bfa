"""Colour casts of lights of other colour temperatures, for testing colour systems off the demo's white light.

A camera whose white balance is fixed for daylight (6,500 K) sees a scene under a tungsten bulb (2,700 K)
orange and under an overcast sky or a cool LED (10,000 K and up) a little blue; one left on its tungsten preset
(3,200 K) sees daylight strongly blue. Every pixel's channels are scaled by the light's colour relative to the
one the camera is balanced for. ``colour_cast`` applies that scaling, which is how the lighting set of
docs/quality.md and the white-balance tests are made.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

#: White-balance presets: the light a camera's balance is set for; its casts are relative to it.
DAYLIGHT_K = 6500.0
TUNGSTEN_K = 3200.0


def blackbody_bgr(kelvin: float) -> np.ndarray:
    """The colour (B, G, R, 0..255) of a black body at ``kelvin`` as an sRGB camera sees it, by Tanner
    Helland's fit to Mitchell Charity's table (within a few levels from 1,000 to 40,000 K)."""
    if not 1000.0 <= kelvin <= 40000.0:
        raise ValueError(f"kelvin {kelvin:g}: the fit holds from 1000 to 40000 K")
    t = kelvin / 100.0
    red = 255.0 if t <= 66 else 329.698727446 * (t - 60) ** -0.1332047592
    green = 99.4708025861 * math.log(t) - 161.1195681661 if t <= 66 else 288.1221695283 * (t - 60) ** -0.0755148492
    if t >= 66:
        blue = 255.0
    elif t <= 19:
        blue = 0.0
    else:
        blue = 138.5177312231 * math.log(t - 10) - 305.0447927307
    return np.clip(np.array([blue, green, red]), 1.0, 255.0)


def cast_gains(kelvin: float, camera_kelvin: float = DAYLIGHT_K) -> np.ndarray:
    """The factors (B, G, R) by which a light of ``kelvin`` scales the channels of a camera balanced for
    ``camera_kelvin``, green kept at 1."""
    relative = blackbody_bgr(kelvin) / blackbody_bgr(camera_kelvin)
    return relative / relative[1]


def colour_cast(image: np.ndarray, kelvin: float, camera_kelvin: float = DAYLIGHT_K) -> np.ndarray:
    """``image`` (BGR ``uint8``, taken in the light its camera was balanced for) as taken under a light of
    ``kelvin`` by a camera balanced for ``camera_kelvin``; channels saturate at 255 as a sensor's do."""
    gains = cast_gains(kelvin, camera_kelvin).astype(np.float32)
    return cv2.transform(image, np.diag(gains))
