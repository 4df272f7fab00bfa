"""PlaneRemovalFilter: remove the dominant plane (the table, the floor) before a shape fit.

PCL's own cylinder tutorial does this first: on a table scene most points are table, and a cylinder
search among them is slow and easily fooled.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from objrec_core import Float, Int

from .base import CloudFilter
from .cloud import PointCloud, as_cloud
from .fitting import fit_plane


class PlaneRemovalFilter(CloudFilter):
    """Finds the largest plane by RANSAC (refined by PCA of its inliers) and drops its points.

    A plane with fewer than ``min_plane_points`` inliers is left alone: it is not a table. With
    ``max_planes`` above one the next largest plane goes too (a floor and a table).
    """

    untuned = {"random_seed": "a seed is no setting to tune: a lucky one does not carry over"}  # noqa: RUF012

    distance_threshold = Float(0.015, "points nearer the plane than this (metres) are removed with it",
                               min=0.001, max=0.2, step=0.001)
    max_iterations = Int(200, "RANSAC draws at most; stops earlier once the plane is certain",
                         min=1, max=10000)
    min_plane_points = Int(2000, "a smaller plane is not removed", min=3, max=10_000_000, soft_max=50_000)
    max_planes = Int(1, "how many planes to remove, largest first", min=1, max=10)
    random_seed = Int(0, "seed of the random draws: the same cloud gives the same result", min=0, max=2**31 - 1)

    def filter(self, frame: Any) -> PointCloud:
        cloud = as_cloud(frame)
        p = self.params
        rng = np.random.default_rng(p.random_seed)
        keep = cloud.valid_mask()
        removed = False
        for _ in range(p.max_planes):
            candidates = np.flatnonzero(keep)
            if candidates.size < p.min_plane_points:  # at least 3, as declared
                break
            plane = fit_plane(cloud.points[candidates], p.distance_threshold, max_iterations=p.max_iterations,
                              rng=rng, origin=cloud.sensor_origin)
            if plane is None or int(plane.inliers.sum()) < p.min_plane_points:
                break
            keep[candidates[plane.inliers]] = False
            removed = True
        return cloud.select(keep) if removed else cloud
