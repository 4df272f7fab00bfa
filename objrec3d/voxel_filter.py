"""VoxelFilter: thin a cloud to one point per cubic voxel, so later stages see evenly spaced points."""

from __future__ import annotations

from typing import Any

import numpy as np

from objrec_core import Bool, Float

from .base import CloudFilter
from .cloud import PointCloud, as_cloud


def voxel_groups(points: np.ndarray, leaf: float) -> tuple[np.ndarray, int]:
    """For each of ``points`` (finite, M x 3), the number of its voxel (0..K-1), and K."""
    return cell_groups(np.floor(points / leaf))


def cell_groups(cells: np.ndarray) -> tuple[np.ndarray, int]:
    """For each row of whole-numbered cell coordinates (float, M x 3), the number of its cell (0..K-1), and K.

    One int64 key per cell where the cells' span allows it (fast); otherwise (a cloud kilometres across in
    millimetre cells, absurd coordinates) the rows are compared whole, which no span can overflow."""
    if cells.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), 0
    cells = cells - cells.min(axis=0)
    span = cells.max(axis=0) + 1
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0**62:
        keys = cells.astype(np.int64)
        width = span.astype(np.int64)
        _, inverse = np.unique((keys[:, 0] * width[1] + keys[:, 1]) * width[2] + keys[:, 2], return_inverse=True)
    else:
        _, inverse = np.unique(cells, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    return inverse, int(inverse.max()) + 1


class VoxelFilter(CloudFilter):
    """Keeps one point per voxel of side ``leaf_size``.

    An organized cloud stays organized (``keep_organized``): in each voxel the point nearest the voxel's
    centroid stays where it is and the others become invalid, so normals can still use the image grid.
    Otherwise the result is PCL's VoxelGrid: the centroid of each voxel, unorganized.
    """

    leaf_size = Float(0.01, "voxel side, metres: larger is faster and coarser", min=0.001, max=1.0, step=0.001)
    keep_organized = Bool(True, "an organized cloud keeps its grid (one original point per voxel) "
                                "instead of becoming the voxel centroids")

    def filter(self, frame: Any) -> PointCloud:
        cloud = as_cloud(frame)
        p = self.params
        valid = np.flatnonzero(cloud.valid_mask())
        if valid.size == 0:
            return cloud
        points = cloud.points[valid].astype(np.float64)
        group, count = voxel_groups(points, p.leaf_size)
        sizes = np.bincount(group, minlength=count).astype(np.float64)
        centroids = np.stack([np.bincount(group, points[:, i], count) for i in range(3)], axis=1) / sizes[:, None]
        if cloud.is_organized and p.keep_organized:
            gap = ((points - centroids[group]) ** 2).sum(axis=1)
            order = np.lexsort((gap, group))
            first = np.ones(order.size, dtype=bool)
            first[1:] = group[order][1:] != group[order][:-1]
            keep = np.zeros(len(cloud), dtype=bool)
            keep[valid[order[first]]] = True
            return cloud.select(keep)
        colors = None
        if cloud.colors is not None:
            colors = np.stack([np.bincount(group, cloud.colors[valid, i].astype(np.float64), count)
                               for i in range(3)], axis=1) / sizes[:, None]
            colors = np.clip(colors + 0.5, 0, 255).astype(np.uint8)
        return PointCloud(centroids.astype(np.float32), colors, sensor_origin=cloud.sensor_origin)
