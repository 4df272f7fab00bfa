"""PlaneRemovalFilter: remove the dominant plane (the table, the floor) before a shape fit.

PCL's own cylinder tutorial does this first: on a table scene most points are table, and a cylinder
search among them is slow and easily fooled.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from objrec_core import Float, Int, Ordered

from .base import CloudFilter
from .cloud import PointCloud, as_cloud
from .fitting import fit_plane
from .plane_checks import PlaneRules, SlabNormals, judge_slab

log = logging.getLogger(__name__)

#: Slabs that prove no plane (an object's face) are set aside and the search goes on, this many times at most
#: (each costs a RANSAC search and its checks, a few milliseconds).
_SET_ASIDE = 1


class PlaneRemovalFilter(CloudFilter):
    """Finds the largest plane by RANSAC (refined by PCA of its inliers) and drops its points.

    A plane with fewer than ``min_plane_points`` inliers is left alone: it is not a table. With
    ``max_planes`` above one the next largest plane goes too (a floor and a table).

    Only planes go (:mod:`objrec3d.plane_checks`): the RANSAC slab is cut into patches connected in the plane,
    and a patch is removed only when its normals agree with the plane's, it is wider than ``min_extent`` times
    the largest object's diameter, and its normals do not curve like a cylinder or sphere of the radius range
    sought (``min_object_radius``-``max_object_radius``; set them to the detector's). A slab that is no plane
    (an object's face: it is what is left when fewer planes are in view than ``max_planes``) is set aside for
    the detector and the next one tried.
    """

    untuned = {"random_seed": "a seed is no setting to tune: a lucky one does not carry over"}  # noqa: RUF012

    distance_threshold = Float(0.015, "points nearer the plane than this (metres) are removed with it",
                               min=0.001, max=0.2, step=0.001)
    max_iterations = Int(200, "RANSAC draws at most; stops earlier once the plane is certain",
                         min=1, max=10000)
    min_plane_points = Int(2000, "a smaller plane is not removed", min=3, max=10_000_000, soft_max=50_000)
    max_planes = Int(1, "how many planes to remove, largest first", min=1, max=10)
    normal_angle = Float(20.0, "degrees: a point's normal within this of the plane's is flat (see min_flat_share)",
                         min=1.0, max=90.0, step=1.0)
    min_flat_share = Float(0.7, "share of a patch's normals that must be flat for it to be a plane (a curved wall "
                           "tangent to the plane is not)", min=0.0, max=1.0, step=0.05)
    min_extent = Float(1.5, "a plane patch narrower than this many diameters of the largest object sought "
                       "(2 x max_object_radius) is an object's face and stays", min=0.0, max=100.0, soft_max=10.0,
                       step=0.1)
    min_object_radius = Float(0.01, "smallest radius of the objects sought (the detector's min_radius): a patch "
                              "whose normals curve like a cylinder or sphere of radius min..max_object_radius "
                              "stays for the detector", min=0.0, max=5.0, soft_max=0.5, step=0.001)
    max_object_radius = Float(0.1, "largest radius of the objects sought (the detector's max_radius); also "
                              "sets min_extent's scale", min=0.001, max=5.0, soft_max=0.5, step=0.001)
    radius_order = Ordered("min_object_radius", "max_object_radius", why="no object radius would be sought")
    random_seed = Int(0, "seed of the random draws: the same cloud gives the same result", min=0, max=2**31 - 1)

    def filter(self, frame: Any) -> PointCloud:
        cloud = as_cloud(frame)
        p = self.params
        rng = np.random.default_rng(p.random_seed)
        keep = cloud.valid_mask()
        search = keep.copy()  # where planes are looked for: without those removed or set aside
        rules = PlaneRules(p.normal_angle, p.min_flat_share, p.min_extent * 2.0 * p.max_object_radius,
                           p.min_plane_points, p.min_object_radius, p.max_object_radius, p.distance_threshold)
        normals: SlabNormals | None = None
        removed = 0
        for _ in range(p.max_planes + _SET_ASIDE):  # a slab set aside does not count: look again, once
            candidates = np.flatnonzero(search)
            if removed >= p.max_planes or candidates.size < p.min_plane_points:  # at least 3, as declared
                break
            plane = fit_plane(cloud.points[candidates], p.distance_threshold, max_iterations=p.max_iterations,
                              rng=rng, origin=cloud.sensor_origin)
            if plane is None or int(plane.inliers.sum()) < p.min_plane_points:
                break
            slab = candidates[plane.inliers]
            normals = normals if normals is not None else SlabNormals(cloud, rng)
            verdict = judge_slab(cloud, slab, plane.normal, normals, rules)
            if not verdict.patches:  # crumbs, no piece of min_plane_points: the slabs left are smaller still
                break
            # A slab with no plane is set aside; of one with a plane, only what is removed: the rest (a wall's foot
            # in the table's slab) may belong to the next plane.
            search[verdict.remove if verdict.remove.size else slab] = False
            keep[verdict.remove] = False
            removed += bool(verdict.remove.size)
            if log.isEnabledFor(logging.DEBUG):
                log.debug("plane %s: %s", plane.normal.round(3), "; ".join(x.describe() for x in verdict.patches))
        return cloud.select(keep) if removed else cloud
