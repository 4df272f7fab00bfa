"""The box rival of a far capped cylinder: the best box a piece's points fit with one axis near the cylinder's.

Beyond 2 m a box seen from above is what a capped cylinder is most often confused with; the segment-then-fit
pass (``cluster_fit``) keeps a cylinder only when no box explains its piece about as well.
"""

from __future__ import annotations

import math

import numpy as np

from .ray_residuals import basis, box_residuals_batch, rotations, truncated_cost
from .robust_fit import robust_least_squares

#: The box rival is started at this many turns about each of its candidate up axes, evenly over 90 degrees (a
#: box turned by 90 degrees about an axis is the same box with two sizes swapped). Started from one turn only
#: (the spread's), the fit stops at a box turned across the true one: far boxes the camera sees from above
#: cost 16-156 more than a capped cylinder there, their true boxes 1-47 less.
BOX_TURNS = 6
#: Function evaluations of each started box fit (the best turn's cost settles within a few).
BOX_EVALUATIONS = 25
#: A box fit stops when its cost or parameters change by less than this share (scipy's default): its budget,
#: ``BOX_EVALUATIONS``, ends most fits first.
BOX_TOLERANCE = 1e-8
#: The box rival is fitted to at most this many of a piece's points (evenly thinned), about the cylinder's
#: axis only (the far boxes' best rivals were all about it): its cost difference is scaled to the whole piece.
BOX_POINTS = 250
#: A box has two more parameters than a capped cylinder (nine against seven): it is a rival when it costs less
#: than ``AMBIGUOUS_COST`` more, less this penalty of two per parameter (the Akaike criterion's).
BOX_PENALTY = 4.0


def box_starts(pts: np.ndarray, up: np.ndarray, sensor: np.ndarray
               ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Starting boxes (frame with ``up`` as its third column, centre, half sizes) for the points of a piece,
    turned by ``BOX_TURNS`` angles about ``up``: sized by the points' spread in each frame and pushed back
    from their middle along the view by half their width (the camera sees a box's front faces only)."""
    centroid = pts.mean(axis=0)
    view = centroid - sensor
    back = view - (view @ up) * up
    back /= max(float(np.linalg.norm(back)), 1e-12)
    u, v = basis(up)
    out = []
    for turn in np.arange(BOX_TURNS) * (0.5 * math.pi / BOX_TURNS):
        first = math.cos(turn) * u + math.sin(turn) * v
        frame = np.stack([first, np.cross(up, first), up], axis=1)
        local = (pts - centroid) @ frame
        low, high = np.percentile(local, 2.0, axis=0), np.percentile(local, 98.0, axis=0)
        half = np.maximum(0.5 * (high - low), 0.01)
        out.append((frame, centroid + frame @ (0.5 * (low + high)) + back * float(half[:2].mean()), half))
    return out


def box_cost(pts: np.ndarray, rays: np.ndarray, sigma: np.ndarray, up: np.ndarray, sensor: np.ndarray) -> float:
    """The ``truncated_cost`` of the box that explains a piece best with one axis near ``up`` (a cylinder's
    axis, or another of the piece's axis candidates): the best of fits started at each of ``box_starts``. The
    rival that tells a box from a capped cylinder."""
    best = math.inf
    for frame0, center0, half0 in box_starts(pts, up, sensor):

        def weighted(xs: np.ndarray, frame0: np.ndarray = frame0) -> np.ndarray:
            frames = np.einsum("kij,jl->kil", rotations(xs[:, :3]), frame0)
            return box_residuals_batch(pts, rays, sensor, frames, xs[:, 3:6], np.abs(xs[:, 6:])) / sigma

        x, _ = robust_least_squares(weighted, np.concatenate([np.zeros(3), center0, half0]), BOX_EVALUATIONS,
                                    ftol=BOX_TOLERANCE, xtol=BOX_TOLERANCE)
        best = min(best, truncated_cost(weighted(x[None])[0]))
    return best
