"""RANSAC fits of planes, spheres and cylinders to points with normals, in NumPy.

Hypotheses are made in vectorised batches and scored with matrix products against a fixed random
subsample of the points (no N x H x 3 temporaries), so a whole cylinder search costs a few milliseconds.

Scoring follows PCL's SACMODEL_*_WITH_NORMALS: a point's cost is
``w * angle + (1 - w) * |distance to the surface|``, where ``angle`` is the angle between the point's
normal and the model's outward surface normal there, and a point is an inlier when that cost is below the
threshold. Normals face the sensor, and the visible surface of a convex object faces it too, so the angle
is signed: the inside of a mug seen through its opening (normals toward the axis) is not the mug's wall.
Hypotheses are ranked by the truncated (MSAC) cost, which separates good from merely large models.

The best hypothesis is refined without trusting an unconstrained least-squares step: proposals (the axis
from the normals, the centre from the normal lines; a sphere's geometric fit started there) are accepted
only if their radius stays within the limits and near the hypothesis, and their RANSAC cost is lower. The
final estimate (``polish``) then fits the inliers' distances alone, along the sensor's rays when the depth
noise is large for the radius; when the normals scatter (far, unorganized clouds) they weigh less.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .ray_residuals import SIDEWAYS_WEIGHT
from .vec import cross3, dot3, norms, pair_dots, row_dots, squared_norms

log = logging.getLogger(__name__)

_BATCH = 256
_SUBSAMPLE = 1024
#: Preemptive scoring: every hypothesis of a batch is scored on about this many points of the search's subsample
#: (every k-th, at least this many), and only the ``PREEMPT_KEEP`` best of them on the whole subsample, which
#: decides the winner and the stopping rule. A quarter of the points rank 256 hypotheses well enough that the one
#: the whole subsample prefers is among the few kept: on the several-shape benchmark's scenes, the fresh table
#: scenes and the hard demo scenes the same objects were found (a cylinder batch costs 2 ms on 1,024 points,
#: 0.5 ms on 256; a search scores one to four batches).
PREEMPT_POINTS = 256
#: How many of a batch's hypotheses, best on ``PREEMPT_POINTS``, are scored on the whole subsample.
PREEMPT_KEEP = 16
_MIN_PAIR_ANGLE = math.radians(8.0)  # two normals closer than this give no usable cylinder axis


@dataclass
class ShapeSettings:
    """What a shape search looks for; see ShapeDetector's parameters for each one's meaning."""

    shape: str = "cylinder"
    min_radius: float = 0.0
    max_radius: float = 0.1
    threshold: float = 0.01
    normal_weight: float = 0.1
    max_iterations: int = 1000
    probability: float = 0.99
    #: Lower the normals' weight where they scatter (see ``_noise_weighted``): for normals from neighbourhoods
    #: of unorganized points; an image grid's normals are smoothed over a fixed window and stay steady.
    noise_weighted: bool = False
    #: The depth noise model: sigma = depth_noise x range^2 (metres at 1 m; 0: none). A point's cost is divided
    #: by max(1, NOISE_SIGMAS x sigma / threshold) (``noise_scale``): far points, as noisy as a small object's
    #: radius is large, are weighed by what the sensor can tell there instead of being cut at a fixed threshold.
    depth_noise: float = 0.0
    #: Where the sensor was, in the coordinates of the points scored (``ransac_shape`` shifts both).
    sensor: np.ndarray | None = None


@dataclass
class ShapeFit:
    """A fitted sphere or cylinder.

    ``center``: the sphere's centre, or a point on the cylinder's axis; ``axis``: the cylinder's unit axis
    (None for a sphere); ``inliers``: indices into the points that were searched.
    """

    shape: str
    center: np.ndarray
    axis: np.ndarray | None
    radius: float
    inliers: np.ndarray
    cost: float
    iterations: int = 0
    #: False when the final least-squares fit was skipped (``ransac_shape``'s ``worth_polishing`` said no).
    polished: bool = True
    #: The normal's weight the inliers were chosen with (lowered where the normals scatter, ``_noise_weighted``).
    normal_weight: float = 0.0


@dataclass
class PlaneFit:
    """A plane ``normal . p + offset = 0`` (unit normal facing the sensor) and its inlier mask."""

    normal: np.ndarray
    offset: float
    inliers: np.ndarray  # boolean mask over the points searched


#: A point within this many sigmas of the depth noise at its range is as good as one within the threshold.
NOISE_SIGMAS = 2.0


def noise_scale(settings: ShapeSettings, points: np.ndarray) -> np.ndarray | None:
    """Per point, what its cost is divided by under the depth noise model (None: 1 everywhere): 1 where the
    noise is small against the threshold (within about 1.8 m for 1.5 mm x z^2 and a 1 cm threshold), growing
    with the square of the range beyond."""
    if settings.depth_noise <= 0 or settings.sensor is None:
        return None
    rel = points - settings.sensor
    sigma = settings.depth_noise * np.einsum("ij,ij->i", rel, rel)
    scale = np.maximum(1.0, (NOISE_SIGMAS / settings.threshold) * sigma)
    return None if not (scale > 1.0).any() else scale


def required_iterations(inlier_ratio: float, sample_size: int, probability: float) -> float:
    """RANSAC's adaptive stopping: draws needed to see one all-inlier sample with ``probability``."""
    good = inlier_ratio**sample_size
    if good <= 0.0:
        return math.inf
    if good >= 1.0:
        return 1.0
    return math.log(1.0 - probability) / math.log(1.0 - good)


# -- planes -----------------------------------------------------------------------------------------------
def fit_plane(
    points: np.ndarray,
    threshold: float,
    *,
    max_iterations: int = 200,
    probability: float = 0.99,
    rng: np.random.Generator | None = None,
    origin: np.ndarray | None = None,
) -> PlaneFit | None:
    """The dominant plane of ``points`` (N x 3, finite) by RANSAC, refined by PCA of its inliers."""
    rng = rng if rng is not None else np.random.default_rng(0)
    n = points.shape[0]
    if n < 3:
        return None
    shift = points[:: max(1, n // 1000)].mean(axis=0, dtype=np.float64)
    local = np.subtract(points, shift.astype(np.float32), dtype=np.float32)
    sample = local[rng.choice(n, size=_SUBSAMPLE, replace=False)] if n > _SUBSAMPLE else local
    best_count, best = -1, None
    done, needed = 0, float(max_iterations)
    while done < min(needed, max_iterations):
        batch = min(_BATCH, max_iterations - done)
        idx = rng.integers(0, sample.shape[0], size=(batch, 3))
        a, b, c = sample[idx[:, 0]], sample[idx[:, 1]], sample[idx[:, 2]]
        normals = cross3(b - a, c - a)
        length = norms(normals)
        # Three points (nearly) on one line define no plane: on a collinear cloud every draw is such a triple.
        ok = length > np.maximum(1e-3 * norms(b - a) * norms(c - a), 1e-9)
        done += batch
        if not ok.any():
            continue
        normals = normals[ok] / length[ok, None]
        offsets = -np.einsum("ij,ij->i", normals, a[ok])
        counts = (np.abs(pair_dots(normals, sample) + offsets[:, None]) < threshold).sum(axis=1)
        k = int(np.argmax(counts))
        if counts[k] > best_count:
            best_count, best = int(counts[k]), (normals[k].astype(np.float64), float(offsets[k]))
            needed = required_iterations(best_count / sample.shape[0], 3, probability)
    if best is None:
        return None
    normal, offset = best
    # Refine by PCA of the inliers among (at most) 20,000 random points, twice.
    refine = (local[rng.choice(n, size=20_000, replace=False)] if n > 20_000 else local).astype(np.float64)
    for _ in range(2):
        chosen = refine[np.abs(dot3(refine, normal) + offset) < threshold]
        if chosen.shape[0] < 3:
            break
        centroid = np.ones(chosen.shape[0]) @ chosen / chosen.shape[0]  # a matrix product: faster than mean
        centred = chosen - centroid
        _, vectors = np.linalg.eigh(centred.T @ centred)
        normal = vectors[:, 0]
        offset = -float(normal @ centroid)
    distance = dot3(local, normal)
    distance += np.float32(offset)
    mask = np.abs(distance) < threshold
    offset -= float(normal @ shift)
    sensor = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    if normal @ sensor + offset < 0:  # face the sensor
        normal, offset = -normal, -offset
    return PlaneFit(normal, offset, mask)


# -- spheres and cylinders -------------------------------------------------------------------------------
def _costs(
    shape: str, centers: np.ndarray, axes: np.ndarray | None, radii: np.ndarray, pts: np.ndarray, nrm: np.ndarray,
    pts_sq: np.ndarray, nrm_dot_pts: np.ndarray, weight: float, scale: np.ndarray | None = None,
    work: tuple[np.ndarray, ...] | None = None,
) -> np.ndarray:
    """Per-point cost for H models x M points (H x M), with matrix products only; divided by ``scale`` (M, the
    depth noise model's, ``noise_scale``) when given. ``work``: four arrays of at least H rows by M of the
    result's dtype to compute in (``_workspace``; the result is a view of the first): a RANSAC search scores
    every batch in the same memory instead of a dozen fresh H x M temporaries (each one's first touch of its
    pages cost as much as the arithmetic). The same operations in the same order as without it: the same bits."""
    h = centers.shape[0]
    if work is None:
        work = _workspace(h, pts.shape[0], np.result_type(centers, pts))
    dist2, nr, along, tmp = (w[:h] for w in work)
    pair_dots(centers, pts, out=dist2)
    np.multiply(dist2, 2.0, out=dist2)
    np.subtract(pts_sq, dist2, out=dist2)
    dist2 += squared_norms(centers)[:, None]  # |p - c|^2
    pair_dots(centers, nrm, out=nr)
    np.subtract(nrm_dot_pts, nr, out=nr)  # n . (p - c)
    if shape != "sphere":
        pair_dots(axes, pts, out=along)
        along -= row_dots(centers, axes)[:, None]
        np.multiply(along, along, out=tmp)
        dist2 -= tmp  # squared distance from the axis
        pair_dots(axes, nrm, out=tmp)
        tmp *= along
        nr -= tmp  # n . radial vector
    np.maximum(dist2, 1e-12, out=dist2)
    dist = np.sqrt(dist2, out=dist2)
    cos = np.divide(nr, dist, out=nr)
    np.clip(cos, -1.0, 1.0, out=cos)
    angle = np.arccos(cos, out=cos)
    angle *= weight
    dist -= radii[:, None]
    cost = np.abs(dist, out=dist)
    cost *= 1.0 - weight
    cost += angle
    if scale is not None:
        cost /= scale
    return cost


def _workspace(rows: int, columns: int, dtype: np.dtype | type = np.float32) -> tuple[np.ndarray, ...]:
    """The four arrays ``_costs`` computes in."""
    return tuple(np.empty((rows, columns), dtype) for _ in range(4))


Hypotheses = tuple[np.ndarray, np.ndarray | None, np.ndarray]  # centres, axes (None: spheres), radii


def _cylinder_hypotheses(p1: np.ndarray, n1: np.ndarray, p2: np.ndarray, n2: np.ndarray,
                         settings: ShapeSettings) -> Hypotheses:
    raw = cross3(n1, n2)
    sin2 = squared_norms(raw)
    ok = sin2 > math.sin(_MIN_PAIR_ANGLE) ** 2
    d = p2 - p1
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.einsum("ij,ij->i", cross3(d, n2), raw) / sin2  # p1 + s n1 reaches the axis
        t = np.einsum("ij,ij->i", cross3(d, n1), raw) / sin2  # p2 + t n2 reaches the axis
    # Outward normals: the axis lies behind both points (s, t < 0); both must see the same radius.
    r1, r2 = -s, -t
    radius = 0.5 * (r1 + r2)
    with np.errstate(invalid="ignore"):
        ok &= (r1 > 0) & (r2 > 0) & (np.abs(r1 - r2) < max(settings.threshold, 0.15 * settings.max_radius))
        ok &= (radius >= settings.min_radius) & (radius <= settings.max_radius)
    axes = raw[ok] / np.sqrt(sin2[ok])[:, None]
    centers = p1[ok] + s[ok, None] * n1[ok]
    return centers, axes, radius[ok]


def _sphere_hypotheses(p1: np.ndarray, n1: np.ndarray, p2: np.ndarray, n2: np.ndarray,
                       settings: ShapeSettings) -> Hypotheses:
    d = p2 - p1
    dd = squared_norms(d)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        r1 = -dd / (2.0 * np.einsum("ij,ij->i", d, n1))  # |p2 - (p1 - r n1)| = r
        r2 = -dd / (-2.0 * np.einsum("ij,ij->i", d, n2))  # |p1 - (p2 - r n2)| = r
        radius = 0.5 * (r1 + r2)
        ok = (r1 > 0) & (r2 > 0) & (np.abs(r1 - r2) < max(settings.threshold, 0.15 * settings.max_radius))
    ok &= (radius >= settings.min_radius) & (radius <= settings.max_radius) & (dd > 1e-10)
    p1, n1, p2, n2, radius = p1[ok], n1[ok], p2[ok], n2[ok], radius[ok]
    centers = 0.5 * ((p1 - radius[:, None] * n1) + (p2 - radius[:, None] * n2))
    return centers, None, radius


def _pair_sampler(points: np.ndarray, cell: float, rng: np.random.Generator
                  ) -> Callable[[int], tuple[np.ndarray, np.ndarray]]:
    """Draw point pairs that lie in one grid cell of size ``cell``: both points of a good sample must be on
    one object, so drawing the second point near the first raises the share of good samples many-fold."""
    keys = np.floor(points / cell).astype(np.int64)
    keys -= keys.min(axis=0)
    span = keys.max(axis=0) + 1
    flat = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
    order = np.argsort(flat, kind="stable")
    ordered = flat[order]
    first = np.empty(ordered.size, dtype=bool)  # where a cell's run starts in the sorted keys
    first[0] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    counts = np.empty_like(starts)
    counts[:-1] = starts[1:] - starts[:-1]
    counts[-1] = ordered.size - starts[-1]
    group = np.empty(points.shape[0], dtype=np.int64)
    group[order] = np.cumsum(first) - 1

    def draw(size: int) -> tuple[np.ndarray, np.ndarray]:
        first = rng.integers(0, points.shape[0], size=size)
        g = group[first]
        second = order[starts[g] + (rng.random(size) * counts[g]).astype(np.int64)]
        return first, second

    return draw


def ransac_shape(
    points: np.ndarray, normals: np.ndarray, settings: ShapeSettings, rng: np.random.Generator,
    origin: np.ndarray | None = None,
    worth_polishing: Callable[[ShapeFit, np.ndarray, np.ndarray], bool] | None = None,
) -> ShapeFit | None:
    """The best sphere or cylinder of ``settings`` among ``points`` (N x 3) with unit ``normals``, or None.
    ``origin``: where the sensor was (the final fit weighs each point's error along its ray from there).
    ``worth_polishing(fit, points, normals)``: asked before the final fit (``polish``, most of a search's time)
    with a copy of the refined fit and the points and normals given here (which it indexes); when it says no,
    the refined fit is returned as it is, marked
    ``polished`` False (a caller rejects it anyway: the final fit moves a model by millimetres, it does not
    turn a sliver into an object)."""
    n = points.shape[0]
    if n < 2:
        return None
    shift = points.mean(axis=0)
    local = (points - shift).astype(np.float32)
    nrm = normals.astype(np.float32)
    if settings.depth_noise > 0 and origin is not None:  # the noise model, in the shifted coordinates
        settings = dataclasses.replace(settings, sensor=np.asarray(origin, dtype=np.float64) - shift)
    m = min(n, _SUBSAMPLE)
    pick = rng.choice(n, size=m, replace=False) if n > m else np.arange(n)
    sp, sn = local[pick], nrm[pick]
    sp_sq, sn_dot = squared_norms(sp), row_dots(sn, sp)
    sp_scale = noise_scale(settings, sp)
    make = _sphere_hypotheses if settings.shape == "sphere" else _cylinder_hypotheses
    draw = _pair_sampler(local, 2.0 * max(settings.max_radius, settings.threshold), rng)
    work = _workspace(min(_BATCH, settings.max_iterations), m)
    # Preemptive scoring where the subsample is at least twice the preemptive sample (otherwise it saves little):
    # on every few of its points, evenly spread (a subsample of fewer than _SUBSAMPLE points is all of them in
    # the cloud's order, so its first rows would be one end of the scene).
    stride = m // PREEMPT_POINTS
    if stride >= 2:
        pre_p, pre_n, pre_sq, pre_dot = sp[::stride], sn[::stride], sp_sq[::stride], sn_dot[::stride]
        pre_p, pre_n = np.ascontiguousarray(pre_p), np.ascontiguousarray(pre_n)
        pre_scale = None if sp_scale is None else sp_scale[::stride]
        pre_work = _workspace(min(_BATCH, settings.max_iterations), pre_p.shape[0])
    t = settings.threshold
    best_cost, best = math.inf, None
    done, needed = 0, math.inf
    while done < min(needed, settings.max_iterations):
        # Tried for speed and dropped: a first batch of 128 and last batches only as large as the
        # draws still needed, and a stopping rule that counts the second point drawn from the first's cell
        # (needing a third of the draws on clutter). Each saved milliseconds a search, and each let a box face
        # or a flat patch through as a cylinder on the hard and fresh scenes (test_3d_hard_demo.py,
        # test_3d_small_far.py): the judge's limits were set on the fits these draws find. Tried again with the
        # visible arc's checks (``arc_checks``): the fresh scenes still lost an object and gained a false one.
        batch = min(_BATCH, settings.max_iterations - done)
        i, j = draw(batch)
        done += batch
        ok = i != j
        centers, axes, radii = make(local[i[ok]], nrm[i[ok]], local[j[ok]], nrm[j[ok]], settings)
        if radii.size == 0:
            continue
        if stride >= 2 and radii.size > PREEMPT_KEEP:
            partial = _costs(settings.shape, centers, axes, radii, pre_p, pre_n, pre_sq, pre_dot,
                             settings.normal_weight, pre_scale, pre_work)
            kept = np.argpartition(np.fmin(partial, t, out=partial).sum(axis=1), PREEMPT_KEEP)[:PREEMPT_KEEP]
            kept.sort()  # in drawing order, so that ties go as they would without the preemptive scoring
            centers, radii = centers[kept], radii[kept]
            axes = None if axes is None else axes[kept]
        cost = _costs(settings.shape, centers, axes, radii, sp, sn, sp_sq, sn_dot, settings.normal_weight, sp_scale,
                      work)
        truncated = np.fmin(cost, t, out=cost)  # the MSAC cost; a point is an inlier where it stays below t
        msac = truncated.sum(axis=1)
        k = int(np.argmin(msac))
        if msac[k] < best_cost:
            best_cost = float(msac[k])
            best = (centers[k].astype(np.float64), None if axes is None else axes[k].astype(np.float64),
                    float(radii[k]))
            needed = required_iterations(int(np.count_nonzero(truncated[k] < t)) / m, 2, settings.probability)
    if best is None:
        return None
    center, axis, radius = best
    pts64, nrm64 = local.astype(np.float64), nrm.astype(np.float64)
    if settings.noise_weighted:
        settings = _noise_weighted(settings, pts64, nrm64, center, axis, radius)
    fit = _refine(settings, pts64, nrm64, center, axis, radius, rounds=2)
    if fit is None:
        return None
    if worth_polishing is not None and not worth_polishing(
            dataclasses.replace(fit, center=fit.center + shift, inliers=fit.inliers.copy()), points, normals):
        fit.polished = False
    else:
        sensor = None if origin is None else np.asarray(origin, dtype=np.float64) - shift
        fit = polish(settings, pts64, nrm64, fit, origin=sensor)
    fit.center = fit.center + shift
    fit.iterations = done
    fit.normal_weight = settings.normal_weight
    return fit


#: Normals scattered by more than this (the median angle, radians, on the model's surface) weigh less.
_NORMAL_NOISE_REF = math.radians(6.0)
_NORMAL_WEIGHT_FLOOR = 0.5
#: The scatter is measured on about this many points (at least), evenly spread.
_SCATTER_POINTS = 4000


def _noise_weighted(settings: ShapeSettings, pts: np.ndarray, nrm: np.ndarray, center: np.ndarray,
                    axis: np.ndarray | None, radius: float) -> ShapeSettings:
    """``settings`` with the normal's weight lowered when the normals on the hypothesis' surface scatter more
    than a few degrees (depth noise of centimetres at 2.5 m leaves unorganized clouds' normals 10-15 degrees
    off): the angle then says less than the distance, and a fixed weight would reject most of a real shape.

    The scatter is measured in the direction a wrong model cannot explain, so that a model that is merely
    wrong is not excused as noisy: a cylinder of the wrong radius or position tilts its normals within the
    cross-section, never along the axis; a sphere's tilts toward or away from the middle of the visible cap,
    never around it. The normals' component in that direction, less what the position on the surface explains,
    is noise alone (its median, times 1.75, is the median angle of isotropic noise)."""
    step = max(1, pts.shape[0] // _SCATTER_POINTS)  # a median needs no more points
    pts, nrm = pts[::step], nrm[::step]
    dist, cos = _residuals(pts, nrm, center, axis, radius)
    band = np.flatnonzero((dist < settings.threshold) & (cos > 0.0))
    if band.size < 8:
        return settings
    if axis is not None:
        sideways = dot3(nrm[band], axis)
        position = dot3(pts[band] - center, axis)[:, None]
    else:
        outward = pts[band] - center
        outward /= np.maximum(norms(outward), 1e-12)[:, None]
        middle = outward.mean(axis=0)
        toward = middle - dot3(outward, middle)[:, None] * outward
        length = norms(toward)
        keep = length > 0.05 * max(float(np.linalg.norm(middle)), 1e-12)
        if keep.sum() < 8:
            return settings
        around = cross3(outward[keep], toward[keep] / length[keep, None])
        sideways = np.einsum("ij,ij->i", nrm[band][keep], around)
        position = outward[keep] - middle / float(np.linalg.norm(middle))
    # Another shape's normals (a sphere's seen as a cylinder) tilt in that direction too, but in step with the
    # position on the surface: what a plane in the position explains is shape, the rest is noise.
    # Fitted to the middle 80 % of the normals: the few that look over an edge would tilt a plain least squares.
    design = np.hstack([position, np.ones((position.shape[0], 1))])
    middle_part = np.abs(sideways) <= np.percentile(np.abs(sideways), 80)
    solution, *_ = np.linalg.lstsq(design[middle_part], sideways[middle_part], rcond=None)
    sideways = sideways - design @ solution
    scatter = 1.75 * float(np.median(np.arcsin(np.clip(np.abs(sideways), 0.0, 1.0))))
    if scatter <= _NORMAL_NOISE_REF:
        return settings
    factor = max(_NORMAL_NOISE_REF / scatter, _NORMAL_WEIGHT_FLOOR)
    log.debug("normals scatter %.1f degrees: normal weight x%.2f", math.degrees(scatter), factor)
    return dataclasses.replace(settings, normal_weight=settings.normal_weight * factor)


def full_costs(settings: ShapeSettings, points: np.ndarray, normals: np.ndarray, center: np.ndarray,
               axis: np.ndarray | None, radius: float) -> np.ndarray:
    """Each point's cost under one model (N)."""
    return _costs(settings.shape, center[None, :], None if axis is None else axis[None, :], np.array([radius]),
                  points, normals, squared_norms(points), row_dots(normals, points),
                  settings.normal_weight, noise_scale(settings, points))[0]


def _msac(costs: np.ndarray, t: float) -> float:
    return float(np.minimum(costs, t).sum())


_SUPPORT_COS = math.cos(math.radians(45.0))
_REFINE_POINTS = 1500
#: The refinement ranks its proposals on about this many points (at least), evenly spread.
_REFINE_SCORED = 4000


def _residuals(pts: np.ndarray, nrm: np.ndarray, center: np.ndarray, axis: np.ndarray | None,
               radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Each point's distance to the surface and the cosine between its normal and the outward surface normal."""
    rel = pts - center
    if axis is not None:
        rel = rel - dot3(rel, axis)[:, None] * axis
    dist = np.maximum(norms(rel), 1e-12)
    return np.abs(dist - radius), np.einsum("ij,ij->i", nrm, rel) / dist


def _refine(settings: ShapeSettings, pts: np.ndarray, nrm: np.ndarray, center: np.ndarray,
            axis: np.ndarray | None, radius: float, rounds: int = 5) -> ShapeFit | None:
    """Improve a hypothesis on its support: the points within the distance threshold whose normals agree
    within 45 degrees (a wider arc than the strict inliers, so the radius is well conditioned). Each round
    proposes models and keeps the one with the smallest truncated combined cost (the RANSAC objective, so
    a least-squares fit that merely chases noise in the distances loses to one the normals agree with), only
    if it is within the radius limits, near the hypothesis and better than the current model."""
    t = settings.threshold
    step = max(1, pts.shape[0] // _REFINE_SCORED)
    all_pts, all_nrm = pts, nrm
    pts, nrm = pts[::step], nrm[::step]  # evenly thinned: the ranking of a few proposals needs no more
    scale = noise_scale(settings, pts)
    reach = t if scale is None else t * scale

    def cost(c: np.ndarray, a: np.ndarray | None, r: float) -> tuple[float, np.ndarray]:
        dist, cos = _residuals(pts, nrm, c, a, r)
        eligible = cos > _SUPPORT_COS
        combined = settings.normal_weight * np.arccos(np.clip(cos, -1.0, 1.0)) + (1 - settings.normal_weight) * dist
        if scale is not None:
            combined /= scale
        return float(np.minimum(combined, t).sum()), eligible & (dist < reach)

    score, support = cost(center, axis, radius)
    for _ in range(rounds):
        if support.sum() < 5:
            break
        chosen = np.flatnonzero(support)
        chosen = chosen[:: max(1, chosen.size // _REFINE_POINTS)]  # evenly thinned: fits need no more
        proposals = (_sphere_proposals(pts[chosen], nrm[chosen], center, radius) if axis is None
                     else _cylinder_proposals(pts[chosen], nrm[chosen], center, axis, radius))
        best = None
        for c2, a2, r2 in proposals:
            if not (settings.min_radius <= r2 <= settings.max_radius) or abs(r2 - radius) > 0.5 * radius + t:
                continue  # a refinement may not wander off: that is how least squares inflates radii
            score2, support2 = cost(c2, a2, r2)
            if best is None or score2 < best[0]:
                best = (score2, c2, a2, r2, support2)
        if best is None or best[0] >= score:
            break
        improved = score - best[0] > 1e-4 * max(score, 1e-9)
        score, center, axis, radius, support = best
        if not improved:
            break
    costs = full_costs(settings, all_pts, all_nrm, center, axis, radius)
    return ShapeFit(settings.shape, center, axis, float(radius), np.flatnonzero(costs < t), _msac(costs, t))


Model = tuple[np.ndarray, np.ndarray | None, float]  # centre, axis (None: sphere), radius


def polish(settings: ShapeSettings, pts: np.ndarray, nrm: np.ndarray, fit: ShapeFit, rounds: int = 8,
           origin: np.ndarray | None = None) -> ShapeFit:
    """The final estimate: a least-squares fit of the inliers' geometric distances only.

    The RANSAC cost mixes the normal's angle into every point's cost, and so does the refinement that
    ranks its proposals by it; smoothed normals on a short arc then pull the radius outward (the mug read
    1.5-2.5 mm too large). Here the inliers (by the RANSAC cost, so the search's choice of points stands)
    decide *which* points count, and only their distances decide *where* the surface is: a sphere's centre
    and radius by Gauss-Newton; a cylinder's axis direction from the inliers' normals (the direction they
    are all perpendicular to: well conditioned on any arc) and its position and radius by a circle fit in
    the plane across it. With the sensor's ``origin`` known, each point's error is measured along its ray,
    as a depth camera errs: a plain geometric fit of the ~120-degree arc a camera sees reads the radius 10-20 %
    small once the depth noise is a tenth of the radius (a 4.5 cm can at 2.25 m read 3.6 cm), the ray fit does
    not. Repeated until the inliers stop changing. A step that leaves the radius limits,
    moves the axis more than 15 degrees or loses a fifth of the inliers is not taken.
    """
    geometric = _polish(settings, pts, nrm, fit, min(rounds, _GEOMETRIC_ROUNDS), None)
    rays = None if origin is None else _unit_rays(pts, origin)
    noise = 0.0 if rays is None else _depth_band(pts, nrm, rays, geometric, settings.threshold)[1]
    if noise < _RAY_FIT_NOISE * geometric.radius:
        return geometric  # little noise for the radius: the geometric fit is as good, and steadier on stereo data
    return _polish(settings, pts, nrm, geometric, rounds, rays)


#: At most about this many points enter each round of the final fit.
_POLISH_POINTS = 2000
#: Rounds of the geometric fit at most: the first lands within a tenth of a millimetre of where it ends; later
#: ones let the inliers creep along the band's edge (the mug's centre 0.1 mm a round, for eight rounds).
_GEOMETRIC_ROUNDS = 4


def _polish(settings: ShapeSettings, pts: np.ndarray, nrm: np.ndarray, fit: ShapeFit, rounds: int,
            all_rays: np.ndarray | None) -> ShapeFit:
    """polish's rounds, by geometric distances (``all_rays`` None) or along the rays."""
    t = settings.threshold
    current = fit
    previous: np.ndarray | None = None
    step = max(1, fit.inliers.size // _POLISH_POINTS)
    for _ in range(rounds):
        chosen = current.inliers if all_rays is None else _depth_band(pts, nrm, all_rays, current, t)[0]
        if chosen.size < 8:
            break
        # Evenly thinned (as exact, a third of the time) by the points' own indices, so that a round whose
        # inliers differ by a few points fits nearly the same points: the rounds settle instead of wandering.
        fitted = chosen[chosen % step == 0] if step > 1 else chosen
        rays = None if all_rays is None else all_rays[fitted]
        if current.axis is None:
            result = (_geometric_fit(pts[fitted], current.center, current.radius) if rays is None
                      else _ray_fit(pts[fitted], rays, current.center, current.radius))
            if result is None:
                break
            center, axis, radius = result[0], None, result[1]
        else:
            agreeing = nrm[current.inliers]  # the axis from the normals that agree with the model, not the band
            _, vectors = np.linalg.eigh(np.einsum("ni,nj->ij", agreeing, agreeing))
            axis = vectors[:, 0] if vectors[:, 0] @ current.axis >= 0 else -vectors[:, 0]
            if axis @ current.axis < math.cos(math.radians(15.0)):
                axis = current.axis
            u = cross3(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
            u /= np.linalg.norm(u)
            v = cross3(axis, u)
            rel = pts[fitted] - current.center
            section = np.stack([dot3(rel, u), dot3(rel, v)], axis=1)
            circle = (_geometric_fit(section, np.zeros(2), current.radius) if rays is None else
                      _ray_fit(section, np.stack([dot3(rays, u), dot3(rays, v)], axis=1), np.zeros(2),
                               current.radius))
            if circle is None:
                break
            center, radius = current.center + circle[0][0] * u + circle[0][1] * v, circle[1]
        if not (settings.min_radius <= radius <= settings.max_radius):
            break
        costs = full_costs(settings, pts, nrm, center, axis, radius)
        inliers = np.flatnonzero(costs < t)
        if inliers.size < 0.8 * current.inliers.size:
            break
        if all_rays is None:
            same = inliers.size == chosen.size and np.array_equal(inliers, chosen)
        else:
            same = previous is not None and np.array_equal(previous, chosen)
            previous = chosen
        tolerance = _SETTLED if all_rays is None else _SETTLED_RAYS
        settled = abs(radius - current.radius) < tolerance and np.linalg.norm(
            _across(center - current.center, axis)) < tolerance and (axis is None or axis @ current.axis > _SETTLED_COS)
        current = ShapeFit(settings.shape, center, axis, float(radius), inliers, _msac(costs, t), fit.iterations)
        if same or settled:
            break
    return current


#: The final fit stops when a round moves the radius and the axis (or centre) by less than this (metres) and
#: the axis direction by less than 0.1 degrees: further rounds of the geometric fit only trade single inliers
#: at the band's edge and wander by a tenth of a millimetre. The ray fit's band moves with the model, and it
#: settles over more rounds.
_SETTLED = 2e-4
_SETTLED_RAYS = 2e-5
_SETTLED_COS = math.cos(math.radians(0.1))


def _across(offset: np.ndarray, axis: np.ndarray | None) -> np.ndarray:
    """The part of ``offset`` across the axis (all of it for a sphere)."""
    return offset if axis is None else offset - (offset @ axis) * axis


def _cylinder_proposals(pts: np.ndarray, nrm: np.ndarray, center: np.ndarray, axis: np.ndarray,
                        radius: float) -> list[Model]:
    """A refined cylinder from the support: the axis from the normals (the direction all of them are
    perpendicular to), the axis position from the normal lines (each passes through the axis) and the median
    radius. (A geometric fit of all five parameters here changed no result: the final fit, ``polish``, is
    geometric, and it cost a sixth of a detection.)"""
    _, vectors = np.linalg.eigh(np.einsum("ni,nj->ij", nrm, nrm))
    a = vectors[:, 0]
    if a @ axis < 0:
        a = -a
    if a @ axis < math.cos(math.radians(15.0)):
        a = axis
    u = cross3(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = cross3(a, u)
    rel = pts - center
    xy = np.stack([dot3(rel, u), dot3(rel, v)], axis=1)
    c2 = _normal_lines_center(xy, np.stack([dot3(nrm, u), dot3(nrm, v)], axis=1))
    proposals = []
    if c2 is not None:
        r2 = float(np.median(norms(xy - c2)))
        proposals.append((center + c2[0] * u + c2[1] * v, a, r2))
    return proposals


def _sphere_proposals(pts: np.ndarray, nrm: np.ndarray, center: np.ndarray, radius: float) -> list[Model]:
    proposals = []
    c2 = _normal_lines_center(pts - center, nrm)
    start = (center, radius)
    if c2 is not None:
        c2 = c2 + center
        r2 = float(np.median(norms(pts - c2)))
        proposals.append((c2, None, r2))
        start = (c2, r2)
    result = _geometric_fit(pts, *start)
    if result is not None:
        proposals.append((result[0], None, result[1]))
    return proposals


def _normal_lines_center(pts: np.ndarray, nrm: np.ndarray) -> np.ndarray | None:
    """The point nearest (least squares) to all lines ``p + s n``: a sphere's centre, or a cylinder's axis in
    the plane perpendicular to it. Linear, and well conditioned even on a short arc."""
    lengths = norms(nrm)
    ok = lengths > 0.3
    if ok.sum() < 3:
        return None
    n = nrm[ok] / lengths[ok, None]
    dim = pts.shape[1]
    projector = np.eye(dim)[None] - n[:, :, None] * n[:, None, :]  # K x d x d
    lhs = projector.sum(axis=0)
    rhs = np.einsum("kij,kj->i", projector, pts[ok])
    if np.linalg.cond(lhs) > 1e8:
        return None
    return np.linalg.solve(lhs, rhs)


def _geometric_fit(pts: np.ndarray, center: np.ndarray, radius: float, iterations: int = 10
                   ) -> tuple[np.ndarray, float] | None:
    """Minimise sum (|p - c| - r)^2 over c and r by Gauss-Newton, for circles (2D) and spheres (3D). The
    normal equations are 3x3 or 4x4: solved directly, a tenth of the time of a least-squares solver."""
    c = np.asarray(center, dtype=np.float64).copy()
    r = float(radius)
    k = pts.shape[1]
    jac = np.empty((pts.shape[0], k + 1))
    jac[:, k] = -1.0
    for _ in range(iterations):
        diff = pts - c
        dist = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        if np.any(dist < 1e-12):
            return None
        residual = dist - r
        np.divide(diff, -dist[:, None], out=jac[:, :k])
        try:
            step = np.linalg.solve(jac.T @ jac, -(jac.T @ residual))
        except np.linalg.LinAlgError:
            return None
        c += step[:-1]
        r += step[-1]
        if not np.isfinite(r) or not np.isfinite(c).all() or r <= 0:
            return None
        if np.abs(step).max() < 1e-7:
            break
    return c, r


_BAND_COS, _BAND_ZONE, _BAND_MAX = 0.5, 3.0, 2.0
#: The ray fit takes over from the geometric fit when the depth noise exceeds this fraction of the radius:
#: there the geometric fit reads radii 5-20 % small (synthetic scenes at 1.5-2.5 m), while below it the two
#: agree on simulated data and the geometric fit matches PCL on the stereo mug scan (the ray fit reads that
#: mug 2.9 mm larger: stereo matching smooths depth across the silhouette, which the ray model trusts).
_RAY_FIT_NOISE = 0.08


def _depth_band(pts: np.ndarray, nrm: np.ndarray, rays: np.ndarray, fit: ShapeFit, t: float
                ) -> tuple[np.ndarray, float]:
    """The points a ray fit should use: those facing the sensor on the model's outer side whose error along
    the ray is within a band set by the measured depth noise (2.5 sigma, at least the threshold, at most 4x).
    The RANSAC inliers are cut at the threshold and by the normals' agreement, which at 7-10 mm of depth
    noise keeps the points that agree with the model's radius, right or wrong; a band as wide as the noise
    lets the fit move to where the points are. Also returns the depth noise measured (sigma, metres)."""
    if fit.inliers.size == 0:
        return fit.inliers, 0.0
    rel = pts - fit.center
    if fit.axis is None:
        section, ray_section = rel, rays
    else:
        section = rel - dot3(rel, fit.axis)[:, None] * fit.axis
        ray_section = rays - dot3(rays, fit.axis)[:, None] * fit.axis
    dist = np.maximum(norms(section), 1e-12)
    facing = np.einsum("ij,ij->i", nrm, section) / dist > _BAND_COS
    if fit.axis is not None:  # no farther along the axis than the inliers reach
        along = dot3(rel, fit.axis)
        reach = along[fit.inliers]
        facing &= (along >= reach.min() - t) & (along <= reach.max() + t)
    candidates = np.flatnonzero(facing & (np.abs(dist - fit.radius) < _BAND_ZONE * t))
    if candidates.size < 8:
        return fit.inliers, 0.0
    error = np.abs(_ray_residuals(section[candidates], ray_section[candidates], np.zeros(3), fit.radius))
    sigma = 1.4826 * float(np.median(error))
    band = min(max(2.5 * sigma, t), _BAND_MAX * t)
    return candidates[error < band], sigma


def _unit_rays(pts: np.ndarray, origin: np.ndarray) -> np.ndarray | None:
    """Unit directions from the sensor to each point; None when a point sits on the sensor."""
    rays = pts - origin
    lengths = norms(rays)
    if np.any(lengths < 1e-9):
        return None
    return rays / lengths[:, None]


def _ray_residuals(pts: np.ndarray, rays: np.ndarray, center: np.ndarray, radius: float) -> np.ndarray:
    """How far each point lies from the circle (2D) or sphere (3D) along its ray: the depth error that puts
    it on the surface (the nearer crossing). ``rays`` may be shorter than unit (a 3D ray seen in a cylinder's
    cross-section); distances stay in units along the 3D ray. A ray that misses: its sideways miss, weighted."""
    rel = pts - center
    a = np.maximum(np.einsum("ij,ij->i", rays, rays), 1e-12)
    b = np.einsum("ij,ij->i", rays, rel)
    q = np.einsum("ij,ij->i", rel, rel)
    disc = b * b - a * (q - radius * radius)
    root = np.sqrt(np.maximum(disc, 0.0))
    near, far = (-b - root) / a, (-b + root) / a
    along = np.where(np.abs(near) <= np.abs(far), near, far)
    miss = np.sqrt(np.maximum(q - b * b / a, 0.0)) - radius
    return np.where(disc >= 0.0, along, SIDEWAYS_WEIGHT * miss)


def _ray_residuals_jacobian(pts: np.ndarray, rays: np.ndarray, center: np.ndarray, radius: float
                            ) -> tuple[np.ndarray, np.ndarray]:
    """``_ray_residuals`` and their derivatives by the centre's coordinates and the radius (N x (k+1)), in
    closed form: the depth error t solves |p - c + t ray|^2 = r^2, so dt/dc = g / (g . ray) and dt/dr =
    r / (g . ray) with g = p - c + t ray (implicit differentiation); a miss's derivatives are those of its
    sideways distance. One evaluation per Gauss-Newton step instead of k + 2 for a numerical Jacobian: the
    final fit of a far object was a third of a whole detection."""
    rel = pts - center
    a = np.maximum(np.einsum("ij,ij->i", rays, rays), 1e-12)
    b = np.einsum("ij,ij->i", rays, rel)
    q = np.einsum("ij,ij->i", rel, rel)
    disc = b * b - a * (q - radius * radius)
    root = np.sqrt(np.maximum(disc, 0.0))
    near, far = (-b - root) / a, (-b + root) / a
    use_near = np.abs(near) <= np.abs(far)
    along = np.where(use_near, near, far)
    hit = disc >= 0.0
    side = rel - (b / a)[:, None] * rays
    side_length = np.maximum(np.sqrt(np.einsum("ij,ij->i", side, side)), 1e-12)
    residual = np.where(hit, along, SIDEWAYS_WEIGHT * (side_length - radius))
    # g . ray = a t + b = -root (near crossing) or +root (far): floored so that a grazing ray (a tangent, where
    # the derivative is unbounded) stays a steep but finite row, as a finite difference would make it.
    floor = 1e-3 * max(radius, 1e-9) * np.sqrt(a)
    grazing = np.where(use_near, -1.0, 1.0) * np.maximum(root, floor)
    g = rel + along[:, None] * rays
    k = pts.shape[1]
    jac = np.empty((pts.shape[0], k + 1))
    jac[:, :k] = np.where(hit[:, None], g / grazing[:, None], -SIDEWAYS_WEIGHT * side / side_length[:, None])
    jac[:, k] = np.where(hit, radius / grazing, -SIDEWAYS_WEIGHT)
    return residual, jac


def _ray_fit(pts: np.ndarray, rays: np.ndarray, center: np.ndarray, radius: float, iterations: int = 12
             ) -> tuple[np.ndarray, float] | None:
    """Centre and radius minimising the points' errors along their rays (Gauss-Newton): the maximum-likelihood
    circle or sphere under depth noise."""
    k = pts.shape[1]
    x = np.concatenate([np.asarray(center, dtype=np.float64), [float(radius)]])
    for _ in range(iterations):
        f0, jac = _ray_residuals_jacobian(pts, rays, x[:k], x[k])
        try:
            step, *_ = np.linalg.lstsq(jac, -f0, rcond=None)
        except np.linalg.LinAlgError:
            return None
        x += step
        if not np.isfinite(x).all() or x[k] <= 0:
            return None
        if np.abs(step).max() < 1e-7:
            break
    return x[:k], float(x[k])
