"""Which points of a piece lie inside its outline as the camera sees it, away from its silhouette.

A depth camera's pixels along a depth jump are *flying pixels*: their depth is a mix of the object's and what
lies behind it, so they hang in the air behind the object's outline (10-20 % of a far object's points at 2.5 m
and beyond). A fit that starts among them bends to take them in: a far cylinder of 4.5 cm read as 9-34 cm.
They are, by how they arise, on the piece's outline in the image; a pixel with all its neighbours in the piece
is not one of them. Outline pixels that do lie on the object are still good points (the silhouette is what
fixes a far cylinder's radius), so this only says where a fit may *start*; its inliers come from all points.

Without the image grid (an unorganized cloud) the pixels are the points' viewing directions in units of
the camera's angle per pixel, so the same test serves both.
"""

from __future__ import annotations

import numpy as np

#: Neighbours are the points within this many pixels' worth of viewing angle (the 8 around a pixel: 1.41).
NEIGHBOUR_PIXELS = 1.5
#: A point with at least this many of its 8 neighbours in the piece is inside its outline (an outline pixel
#: has 5 at most on a straight edge; a random dropout next to an inside pixel leaves it 7).
LEAST_NEIGHBOURS = 7


def inside_outline(points: np.ndarray, sensor: np.ndarray, pixel_angle: float) -> np.ndarray:
    """Whether each of ``points`` (one piece) has at least ``LEAST_NEIGHBOURS`` neighbours among the others
    within ``NEIGHBOUR_PIXELS`` pixels of viewing angle (``pixel_angle`` radians per pixel)."""
    if points.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    from scipy.spatial import cKDTree

    rel = points - sensor
    rel = rel / np.linalg.norm(rel, axis=1, keepdims=True)
    # The direction's two coordinates across the piece's mean viewing direction (a tangent plane there).
    middle = rel.mean(axis=0)
    middle /= np.linalg.norm(middle)
    first = np.cross(middle, [1.0, 0.0, 0.0] if abs(middle[0]) < 0.9 else [0.0, 1.0, 0.0])
    first /= np.linalg.norm(first)
    second = np.cross(middle, first)
    image = np.stack([rel @ first, rel @ second], axis=1) / (rel @ middle)[:, None] / pixel_angle
    tree = cKDTree(image)
    counts = tree.query_ball_point(image, NEIGHBOUR_PIXELS, return_length=True) - 1
    return counts >= LEAST_NEIGHBOURS
