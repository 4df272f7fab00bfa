"""The 2D annotation keeps every detection's name whole inside the image, also for an object at the right or
top edge (a truncated object, cut by the frame, is exactly where a clipped name would hide it)."""

from __future__ import annotations

import cv2
import numpy as np

from objrec2d import DetectedObject2D, draw_objects
from objrec2d.annotate import FONT, FONT_SCALE, label_origin
from objrec2d.messages import Polygon

NAME = "coloured_object"


def _drawn_columns(image: np.ndarray) -> np.ndarray:
    """Columns holding any non-black pixel."""
    return np.flatnonzero(image.any(axis=(0, 2)))


def test_a_name_at_the_right_edge_is_moved_inwards_and_drawn_whole():
    width, height = 320, 240
    square = Polygon.from_xy([(300, 100), (319, 100), (319, 140), (300, 140)])
    drawn = draw_objects(np.zeros((height, width, 3), np.uint8), [DetectedObject2D(NAME, square)], thickness=1)
    (text_width, _), _ = cv2.getTextSize(NAME, FONT, FONT_SCALE, 1)
    x, y = label_origin(drawn.shape, np.array(square.xy(), np.float32), NAME)
    assert x + text_width <= width - 1
    assert x < 300  # moved left of the outline's corner
    text_rows = drawn[max(0, y - 14):y + 3, :, :]
    assert _drawn_columns(text_rows).min() <= x + 2  # the name's first letter is in the picture, not cut


def test_a_name_at_the_top_edge_stays_below_it_and_a_roomy_one_sits_above_its_object():
    shape = (240, 320, 3)
    top = np.array([(50, 0), (90, 0), (90, 30), (50, 30)], np.float32)
    x, y = label_origin(shape, top, NAME)
    (_, text_height), _ = cv2.getTextSize(NAME, FONT, FONT_SCALE, 1)
    assert y - text_height >= 0 and x == 50
    middle = np.array([(50, 100), (90, 100), (90, 130), (50, 130)], np.float32)
    assert label_origin(shape, middle, NAME) == (50, 95)
