"""Small vector helpers that avoid BLAS for N x 3 data.

A product with a 3-vector is three multiplies and two adds; handed to a multi-threaded BLAS it costs
10-50x more whenever the machine is busy (its threads wait for cores), which is exactly when a robot's
detector must not slow down.
"""

from __future__ import annotations

import numpy as np


def dot3(points: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``points @ vector`` for an N x 3 array and a 3-vector (result in the points' dtype)."""
    v = np.asarray(vector, dtype=points.dtype)
    return points[:, 0] * v[0] + points[:, 1] * v[1] + points[:, 2] * v[2]


def pair_dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b.T`` for H x 3 and M x 3 arrays (H x M)."""
    out = a[:, 0, None] * b[None, :, 0]
    out += a[:, 1, None] * b[None, :, 1]
    out += a[:, 2, None] * b[None, :, 2]
    return out
