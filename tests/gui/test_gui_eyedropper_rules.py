"""The eyedropper's two rules for shaded, glossy objects, on made-up pixels: a pure-primary peak (a colour
clipped to the corner of the sensor's gamut) parts from the colour beside it, any other neighbouring peak is
the object's own shading and joins it; and the hue range grows by the object's own hue spread on each side."""

from __future__ import annotations

import cv2
import numpy as np

from objrec_apps.gui.eyedropper import HUE_MARGIN, at_gamut_corner, hsv_ranges, semi_deviations


def pixels_of_hues(hues: dict[int, int], saturation: int = 200, value: int = 240) -> np.ndarray:
    """BGR pixels (N x 3): ``count`` pixels of each OpenCV hue, at the given saturation and value."""
    hsv = np.concatenate([np.tile([hue, saturation, value], (count, 1)) for hue, count in hues.items()])
    return cv2.cvtColor(hsv.astype(np.uint8).reshape(-1, 1, 3), cv2.COLOR_HSV2BGR).reshape(-1, 3)


def test_pure_primaries_are_at_the_gamut_corner_and_a_shadowed_blue_is_not():
    bgr = np.array([[0, 0, 241], [0, 241, 0], [232, 0, 0], [232, 0, 72], [40, 35, 215]], np.uint8)
    hsv = cv2.cvtColor(bgr.reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3).astype(np.int64)
    assert at_gamut_corner(hsv).tolist() == [True, True, True, False, False]


def test_a_shadow_peak_beside_the_body_is_the_same_colour():
    """A blue body at hues 104-110 and its shadowed side, a peak of its own at 129-130 across a thin valley:
    one colour, so the range takes both."""
    body = {hue: 300 for hue in range(104, 111)} | {hue: 25 for hue in range(111, 129)}
    blue = pixels_of_hues(body | {129: 200, 130: 60})
    values = hsv_ranges(blue)
    assert values["h_min"] <= 104 and values["h_max"] >= 130


def test_a_pure_red_peak_beside_orange_stays_out_of_the_orange_range():
    """An orange body (hues 4-16) whose most saturated part is clipped to pure red (0, 0, 240): the red peak
    is another colour's too, so the orange range stops short of hue 0 and does not wrap."""
    orange = pixels_of_hues({1: 25, 2: 30, 3: 50} | {hue: 250 for hue in range(4, 17)} | {17: 40, 18: 10})
    clipped_red = np.tile(np.array([0, 0, 240], np.uint8), (400, 1))
    values = hsv_ranges(np.concatenate([orange, clipped_red]))
    assert 0 < values["h_min"] <= 4 and values["h_min"] < values["h_max"] <= 25


def test_the_range_grows_by_the_spread_on_each_side_and_by_the_margin_at_least():
    """Hues piled at 60 with a long tail up to 75: the tail's side grows by its spread, the other side by the
    margin only."""
    hues = {60: 2000} | {hue: 60 for hue in range(61, 76)}
    below, above = semi_deviations(np.repeat(list(hues), list(hues.values())).astype(np.float64))
    assert below == 0.0 and above > HUE_MARGIN
    values = hsv_ranges(pixels_of_hues(hues))
    assert values["h_min"] == 60 - HUE_MARGIN
    assert values["h_max"] >= 75 + int(np.ceil(above)) - 1  # the 99th percentile may sit a hue under the tail's end
