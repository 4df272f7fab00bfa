"""Distances on a grid to the nearest zero cell, the same on every call.

Every clearance of the navigation stack (the costmap's inflation, the planner's keepout, amcl's likelihood
field, the passages between rooms) comes from OpenCV's exact Euclidean distance transform. Its float32 result
differs in the last bit from one call to the next on the same grid (on two threads, about half the calls:
whether a column goes through the vectorised or the scalar path depends on how the work was split), and a
simulation grows such a bit into a different run: the same seed ended a corridor run with 0 or 1 aborted goals
from one process to the next. The transform is exact, so every distance it returns stands for the square root
of a whole number of squared cells; snapping it there gives one answer, and a slightly truer one.
"""

from __future__ import annotations

import cv2
import numpy as np

#: Below this distance (in cells) float32's rounding of the distance moves its square by less than half a cell
#: squared, so the snap is exact; farther (grids over 2,048 cells across) the value is left as OpenCV gives it.
EXACT_BELOW = 2048.0


def distance_to_zero(grid: np.ndarray) -> np.ndarray:
    """Per cell of ``grid`` (uint8, zero where the distance is measured to), the Euclidean distance in cells
    from its centre to the nearest zero cell's centre, as float64, identical on every call."""
    dist = cv2.distanceTransform(grid, cv2.DIST_L2, cv2.DIST_MASK_PRECISE).astype(np.float64)
    if max(dist.shape) < EXACT_BELOW:  # no distance on the grid can reach the limit: snap in place
        np.square(dist, out=dist)
        np.rint(dist, out=dist)
        np.sqrt(dist, out=dist)
    else:
        near = dist < EXACT_BELOW
        dist[near] = np.sqrt(np.rint(dist[near] ** 2))
    return dist
