"""ShapeDetector: spheres or cylinders by RANSAC on points with normals, reported as oriented boxes.

PCL's SACSegmentationFromNormals always returns its best model, however bad, and needs a slow
k-nearest-neighbour normal estimation first. Here normals come from the image grid when the cloud is
organized, hypotheses from two points with normals are rejected before scoring when their radius
is out of range, and a fit becomes an object only when it is strong: enough inliers in one connected
piece, covering enough of the shape's visible side (``min_arc``). A scene without the shape gives nothing.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from objrec_core import Choice, Float, Int, Ordered

from .base import CloudDetector
from .cloud import PointCloud, as_cloud
from .fitting import ShapeFit, ShapeSettings, ransac_shape
from .messages import DetectedObject3D, OrientedBox, Point, Pose, Quaternion
from .normals import grid_normals, knn_normals
from .vec import dot3

log = logging.getLogger(__name__)


class ShapeDetector(CloudDetector):
    """Finds up to ``max_objects`` spheres or cylinders: fit, remove the inliers, fit again."""

    shape = Choice("cylinder", ["sphere", "cylinder"], "the shape to find")
    # Things a robot picks up are a few centimetres across: the sliders stop at half a metre, typed values
    # reach 5 m. Both share the range so that the two sliders line up.
    min_radius = Float(0.01, "smallest radius reported, metres", min=0.0, max=5.0, soft_max=0.5, step=0.001)
    max_radius = Float(0.1, "largest radius reported, metres; also bounds the pair sampling", min=0.001, max=5.0,
                       soft_max=0.5, step=0.001)
    radius_order = Ordered("min_radius", "max_radius", why="no radius could be reported")
    distance_threshold = Float(0.01, "a point is an inlier when w*angle + (1-w)*distance is below this (PCL's "
                               "threshold)", min=0.0005, max=0.5, step=0.0005)
    normal_distance_weight = Float(0.05, "w: how much the normal's angle (radians) counts against the "
                                   "distance (metres)", min=0.0, max=1.0, step=0.01)
    max_iterations = Int(1000, "hypotheses tried at most per object", min=1, max=100_000, soft_max=10_000, step=1)
    probability = Float(0.99, "adaptive stopping: stop once a better model is this unlikely", min=0.5, max=0.99999,
                        step=0.001)
    min_inliers = Int(300, "a fit with fewer inliers (in its largest connected piece) is no object", min=3,
                      max=10_000_000, soft_max=5000)
    min_arc = Float(60.0, "degrees the inliers must cover: of the circumference (cylinder), of the cap across its "
                    "narrower side (sphere); a sliver of a plane, an edge or a ring is no shape", min=0.0, max=360.0,
                    step=5.0)
    min_length = Float(0.8, "cylinders: the inliers must reach this many radii along the axis; a ring around a "
                       "sphere is no cylinder", min=0.0, max=100.0, soft_max=10.0, step=0.1)
    min_agreement = Float(0.5, "share of the points on the fitted surface (within the threshold, facing out) whose "
                          "normals must agree with it: the rounded edge of a flat thing does not", min=0.0, max=1.0,
                          step=0.05)
    max_objects = Int(1, "objects per cloud at most", min=1, max=50)
    normal_window = Int(3, "organized clouds: half-size in pixels of the box that smooths the normals (its footprint "
                        "is twice that: keep it well under an object's radius in pixels)", min=1,
                        max=50)
    normal_neighbours = Int(30, "unorganized clouds: neighbours per normal", min=3, max=200)
    random_seed = Int(0, "seed of the random draws, reset for every cloud: the same cloud gives the same "
                      "objects", min=0, max=2**31 - 1)

    def detect(self, frame: Any) -> list[DetectedObject3D]:
        cloud = as_cloud(frame)
        return [self._to_object(fit, extent, cloud.sensor_origin) for fit, extent in self.find(cloud)]

    # -- the search ------------------------------------------------------------------------------------------
    def find(self, cloud: PointCloud) -> list[tuple[ShapeFit, tuple[np.ndarray, float]]]:
        """The accepted fits with their box centre and height (indices of ``inliers`` are into the valid
        points that have normals, see ``points_with_normals``)."""
        p = self.params
        points, normals, _ = self.points_with_normals(cloud, p)
        if points.shape[0] < p.min_inliers:
            return []
        settings = ShapeSettings(
            shape=p.shape, min_radius=p.min_radius, max_radius=p.max_radius,
            threshold=p.distance_threshold, normal_weight=p.normal_distance_weight,
            max_iterations=p.max_iterations, probability=p.probability,
        )
        rng = np.random.default_rng(p.random_seed)
        alive = np.arange(points.shape[0])
        found: list[tuple[ShapeFit, tuple[np.ndarray, float]]] = []
        attempts = p.max_objects + 6  # a rejected fit's points are set aside and the search goes on
        while len(found) < p.max_objects and attempts > 0 and alive.size >= p.min_inliers:
            attempts -= 1
            fit = ransac_shape(points[alive], normals[alive], settings, rng)
            if fit is None:
                break
            fit.inliers = alive[fit.inliers]
            verdict = self._judge(fit, points, normals, settings, p)
            if verdict is None:
                center, height = self._extent(fit, points)
                found.append((fit, (center, height)))
                log.debug("%s: %s r=%.4f with %d inliers", self.label, fit.shape, fit.radius, fit.inliers.size)
            else:
                log.debug("%s: rejected %s r=%.4f: %s", self.label, fit.shape, fit.radius, verdict)
            alive = np.setdiff1d(alive, fit.inliers, assume_unique=True)
        return found

    def points_with_normals(self, cloud: PointCloud, p: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The valid points that have a normal (float64), their normals, and their indices in the cloud."""
        p = self.params if p is None else p
        index = np.flatnonzero(cloud.valid_mask())
        if index.size == 0:
            return np.empty((0, 3)), np.empty((0, 3)), index
        normals = None
        if cloud.is_organized:
            normals = grid_normals(cloud, index, window=p.normal_window)
            if np.isfinite(normals[:, 0]).mean() < 0.5:  # a sparse grid (voxel-thinned): use neighbours
                normals = None
        if normals is None:
            normals = knn_normals(cloud.points[index], p.normal_neighbours, cloud.sensor_origin)
        ok = np.isfinite(normals[:, 0])
        return cloud.points[index[ok]].astype(np.float64), normals[ok].astype(np.float64), index[ok]

    def _judge(self, fit: ShapeFit, points: np.ndarray, normals: np.ndarray, settings: ShapeSettings, p: Any
               ) -> str | None:
        """None for a strong fit (keeping only its largest connected piece of inliers), else why not."""
        if fit.inliers.size < p.min_inliers:
            return f"{fit.inliers.size} inliers < {p.min_inliers}"
        cell = max(0.25 * fit.radius, 1.5 * settings.threshold, 0.004)
        fit.inliers = fit.inliers[largest_cluster(points[fit.inliers], cell)]
        if fit.inliers.size < p.min_inliers:
            return f"{fit.inliers.size} connected inliers < {p.min_inliers}"
        arc = coverage(fit, points[fit.inliers])
        if arc < p.min_arc:
            return f"inliers cover {arc:.0f} degrees < {p.min_arc:g}"
        if fit.axis is not None:
            along = dot3(points[fit.inliers] - fit.center, fit.axis)
            length = float(along.max() - along.min())
            if length < p.min_length * fit.radius:
                return f"inliers reach {length:.3f} m along the axis < {p.min_length:g} radii"
        agreement = normal_agreement(fit, points, normals, settings.threshold)
        if agreement < p.min_agreement:
            return f"normals agree on {agreement:.0%} of the surface < {p.min_agreement:.0%}"
        return None

    @staticmethod
    def _extent(fit: ShapeFit, points: np.ndarray) -> tuple[np.ndarray, float]:
        if fit.axis is None:
            return fit.center, 2.0 * fit.radius
        along = dot3(points[fit.inliers] - fit.center, fit.axis)
        # The box: centred on the inlier centroid projected onto the axis, as long as the inliers reach along it.
        return fit.center + fit.axis * along.mean(), float(along.max() - along.min())

    def _to_object(self, fit: ShapeFit, extent: tuple[np.ndarray, float], sensor: np.ndarray) -> DetectedObject3D:
        center, height = extent
        diameter = 2.0 * fit.radius
        if fit.axis is None:
            orientation = Quaternion()
        else:
            orientation = Quaternion.from_matrix(box_rotation(fit.axis, center, sensor))
        box = OrientedBox(Pose(Point(*(float(v) for v in center)), orientation), diameter, height, diameter)
        return DetectedObject3D(self.object_name, box, fit.shape, float(fit.radius), int(fit.inliers.size))


def box_rotation(axis: np.ndarray, center: np.ndarray, sensor: np.ndarray | None = None) -> np.ndarray:
    """The cylinder box's rotation: local y along the axis, local z toward the sensor, x = y cross z.

    Axis sign convention: the axis points toward the sensor's side, ``axis . (sensor - centre) >= 0`` (as
    normals do; an upright mug's axis then agrees with the table normal); when the axis is perpendicular to
    the line of sight, it points up in the image (negative y).
    """
    sensor = np.zeros(3) if sensor is None else np.asarray(sensor, dtype=np.float64)
    y = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    view = sensor - center
    dot = float(y @ view)
    if abs(dot) <= 1e-6 * np.linalg.norm(view):
        dot = -y[1] if abs(y[1]) > 1e-9 else y[0]
    if dot < 0:
        y = -y
    z = view - (view @ y) * y
    if np.linalg.norm(z) < 1e-9:  # looking straight along the axis
        z = np.cross(y, [1.0, 0.0, 0.0] if abs(y[0]) < 0.9 else [0.0, 1.0, 0.0])
    z /= np.linalg.norm(z)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=1)


def oriented_axis(axis: np.ndarray, center: np.ndarray) -> np.ndarray:
    """``axis`` with the sign convention of ``box_rotation``."""
    return box_rotation(axis, center)[:, 1]


def largest_cluster(points: np.ndarray, cell: float) -> np.ndarray:
    """Indices of the largest group of points connected through neighbouring voxels of side ``cell``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if points.shape[0] == 0:
        return np.arange(0)
    keys = np.floor(points / cell).astype(np.int64)
    keys -= keys.min(axis=0) - 1
    span = keys.max(axis=0) + 2
    flat = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
    cells, inverse = np.unique(flat, return_inverse=True)
    inverse = inverse.reshape(-1)
    rows, cols = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (0, 1):
                if dz == 0 and (dx, dy) <= (0, 0):
                    continue  # each neighbour pair once
                target = cells + (dx * span[1] + dy) * span[2] + dz
                at = np.searchsorted(cells, target)
                at[at == cells.size] = 0
                hit = cells[at] == target
                rows.append(np.flatnonzero(hit))
                cols.append(at[hit])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size, dtype=np.int8), (r, c)), shape=(cells.size, cells.size))
    _, label = connected_components(graph, directed=False)
    point_label = label[inverse]
    return np.flatnonzero(point_label == np.bincount(point_label).argmax())


def coverage(fit: ShapeFit, inliers: np.ndarray) -> float:
    """How much of the shape the inliers cover, in degrees: the longest run of the circumference around
    a cylinder's axis (10-degree bins), or twice the 95th-percentile angle of a sphere's inlier directions
    from their mean (the cap's angular diameter)."""
    if inliers.shape[0] == 0:
        return 0.0
    rel = inliers - fit.center
    if fit.axis is None:
        # A cap is two-dimensional: measure its extent across its narrower direction, so that a ring of
        # inliers around a sphere (a cylinder's side touching it) does not count as a sphere.
        directions = rel / np.linalg.norm(rel, axis=1, keepdims=True)
        mean = directions.mean(axis=0)
        mean /= np.linalg.norm(mean)
        tangent = directions - dot3(directions, mean)[:, None] * mean
        _, vectors = np.linalg.eigh(np.einsum("ni,nj->ij", tangent, tangent))
        minor = vectors[:, 1]  # eigenvalue 0 belongs to `mean`; the next smallest is the narrow direction
        spread = np.percentile(np.abs(dot3(tangent, minor)), 95)
        return float(2.0 * np.degrees(np.arcsin(min(spread, 1.0))))
    axis = fit.axis
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    theta = np.degrees(np.arctan2(dot3(rel, v), dot3(rel, u))) % 360.0
    counts = np.bincount((theta // 10).astype(int) % 36, minlength=36)
    occupied = counts >= max(2, 0.1 * inliers.shape[0] / 36)
    if occupied.all():
        return 360.0
    run = best = 0
    for flag in np.concatenate([occupied, occupied]):
        run = run + 1 if flag else 0
        best = max(best, run)
    return float(10 * min(best, 36))


def normal_agreement(fit: ShapeFit, points: np.ndarray, normals: np.ndarray, threshold: float) -> float:
    """Inliers / points on the model's surface: within ``threshold`` of it, facing outward, and (cylinder)
    within the inliers' extent along the axis. A real shape's normals agree nearly everywhere on it."""
    rel = points - fit.center
    band = np.ones(points.shape[0], dtype=bool)
    if fit.axis is not None:
        along = dot3(rel, fit.axis)
        inlier_along = along[fit.inliers]
        band = (along >= inlier_along.min()) & (along <= inlier_along.max())
        rel = rel - along[:, None] * fit.axis
    dist = np.maximum(np.linalg.norm(rel, axis=1), 1e-12)
    band &= (np.abs(dist - fit.radius) < threshold) & (np.einsum("ij,ij->i", normals, rel) > 0)
    return fit.inliers.size / max(int(band.sum()), 1)


def axis_angle_degrees(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two lines (axes), 0..90 degrees."""
    cos = abs(float(np.dot(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.degrees(math.acos(min(cos, 1.0)))
