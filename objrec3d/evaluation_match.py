"""Matching a frame's detected shapes to its truth shapes, and counting the points that show a truth shape.

A detection and a truth shape match when their centres lie within the truth's gate,
``max(match_distance, match_share x scale)`` metres, where ``scale`` is the truth's radius (half a box's
smallest side). Why the centre and not a volume overlap: a detector sees one side of an object, so its box
covers the visible part and an IoU of boxes punishes what no sensor could see; the centre of a fitted sphere
or cylinder is the figure a robot grasping it needs. The default gate (5 cm, or half the radius of a large
object) passes a fit that lands on the object and refuses one on its neighbour.

The matching is one-to-one and optimal (``objrec3d.tracking.min_cost_assignment``, exact like SciPy's
``linear_sum_assignment``): first as many pairs as possible within the gates, then as many whose names
agree, then the smallest total distance. A pair whose names differ is kept so that a shape-type confusion is
seen (a cylinder reported as a sphere), but it counts as a miss and a false detection.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .messages import DetectedObject3D
from .tracking import min_cost_assignment
from .truth import TruthShape

#: A disallowed pair's cost: larger than any sum of allowed ones.
_FORBIDDEN = 1.0e9
#: What a name that differs costs: more than any distance, less than leaving a pair unmatched.
_OTHER_NAME = 1.0e4


@dataclass(frozen=True)
class Gate:
    """How near a detection's centre must be to a truth's: ``max(distance, share x truth.scale)`` metres."""

    distance: float = 0.05
    share: float = 0.5

    def __post_init__(self) -> None:
        if not (self.distance > 0 and math.isfinite(self.distance)):
            raise ValueError(f"match_distance={self.distance!r} must be a positive number of metres")
        if not (self.share >= 0 and math.isfinite(self.share)):
            raise ValueError(f"match_share={self.share!r} must be 0 or more (a share of the truth's radius)")

    def of(self, truth: TruthShape) -> float:
        return max(self.distance, self.share * truth.scale)


@dataclass(frozen=True)
class FrameMatch:
    """One frame's matching: ``pairs`` of (truth index, detection index, centre distance), the rest unmatched."""

    pairs: tuple[tuple[int, int, float], ...]
    lone_truths: tuple[int, ...]
    lone_detections: tuple[int, ...]


def centre_distances(truths: Sequence[TruthShape], detections: Sequence[DetectedObject3D]) -> np.ndarray:
    """Truths x detections matrix of centre distances (metres)."""
    if not truths or not detections:
        return np.zeros((len(truths), len(detections)))
    t = np.array([s.centre for s in truths], dtype=float)
    d = np.array([o.center for o in detections], dtype=float)
    return np.linalg.norm(t[:, None, :] - d[None, :, :], axis=2)


def match_frame(truths: Sequence[TruthShape], detections: Sequence[DetectedObject3D], gate: Gate) -> FrameMatch:
    """The optimal one-to-one matching of one frame (see the module's docstring)."""
    distance = centre_distances(truths, detections)
    pairs: list[tuple[int, int, float]] = []
    if distance.size:
        gates = np.array([gate.of(t) for t in truths])[:, None]
        allowed = np.isfinite(distance) & (distance <= gates)
        names = np.array([[t.name != d.name for d in detections] for t in truths])
        cost = np.where(allowed, np.nan_to_num(distance) + _OTHER_NAME * names, _FORBIDDEN)
        pairs = [(r, c, float(distance[r, c])) for r, c in min_cost_assignment(cost) if allowed[r, c]]
    matched_t = {p[0] for p in pairs}
    matched_d = {p[1] for p in pairs}
    return FrameMatch(tuple(pairs), tuple(i for i in range(len(truths)) if i not in matched_t),
                      tuple(j for j in range(len(detections)) if j not in matched_d))


def axis_angle_deg(a: Sequence[float], b: Sequence[float]) -> float:
    """The angle between two axes in degrees, 0..90: an axis has no sign."""
    u, v = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    cos = abs(float(u @ v)) / max(float(np.linalg.norm(u) * np.linalg.norm(v)), 1e-12)
    return math.degrees(math.acos(min(1.0, cos)))


def reach(shape: TruthShape) -> float:
    """How far the solid reaches from its centre (metres): a bounding sphere's radius."""
    if shape.shape == "cylinder":
        return math.hypot(shape.radius, 0.5 * shape.height)
    if shape.shape == "box" and shape.size is not None:
        return 0.5 * math.sqrt(sum(s * s for s in shape.size))
    return shape.radius


def visible_points(points: np.ndarray, shape: TruthShape, tolerance: float) -> int:
    """How many of ``points`` (N x 3, finite) lie on or within ``tolerance`` metres of the solid ``shape``:
    the points that show it (points inside a solid are sensor noise on its surface)."""
    centre = np.asarray(shape.centre, dtype=float)
    near = points[np.linalg.norm(points - centre, axis=1) <= reach(shape) + tolerance] - centre
    if shape.shape == "sphere" or near.shape[0] == 0:
        return int(near.shape[0])
    if shape.shape == "cylinder":
        axis = np.asarray(shape.axis if shape.axis is not None else (0.0, 0.0, 1.0), dtype=float)
        along = near @ axis
        radial = np.linalg.norm(near - np.outer(along, axis), axis=1)
        inside = (np.abs(along) <= 0.5 * shape.height + tolerance) & (radial <= shape.radius + tolerance)
        return int(inside.sum())
    half = 0.5 * np.asarray(shape.size if shape.size is not None else (0.0, 0.0, 0.0), dtype=float)
    local = near @ shape.rotation()
    return int((np.abs(local) <= half + tolerance).all(axis=1).sum())


def visible_counts(points: np.ndarray, shapes: Sequence[TruthShape], tolerance: float) -> list[int]:
    """:func:`visible_points` of each shape in a whole cloud's points (N x 3, NaN where there is no return):
    a box test on the coordinate columns first (NaN fails it), so a frame of 300 000 points costs about a
    millisecond per shape, not ten (the quality strip and a tuning search score the same frames again)."""
    columns = np.ascontiguousarray(np.asarray(points).T)
    counts = []
    for shape in shapes:
        r = reach(shape) + tolerance
        x, y, z = shape.centre
        near = (np.abs(columns[0] - x) <= r) & (np.abs(columns[1] - y) <= r) & (np.abs(columns[2] - z) <= r)
        counts.append(visible_points(columns[:, near].T.astype(np.float64), shape, tolerance))
    return counts
