"""Segment first, then fit: far and small objects that the hypothesis search leaves behind.

The search draws hypotheses from pairs of points with normals and counts inliers by a fixed threshold that
mixes distance and normal angle. Beyond about 2 m a depth camera's noise (sigma = 1.5 mm x range^2: 11 mm
at 2.7 m) is a quarter of a 4 cm radius: the best hypothesis has the right radius but only a fifth of the
object's points fall within the threshold, and the smoothed normals are bent at the rim and silhouette. The
object is still there as a *piece of the cloud*: this pass (PCL's classic path) takes the points no object
has taken, splits them into connected pieces, and fits each piece of a plausible size by its point positions
alone, each point's error measured along its ray and in units of the depth noise expected at its range:

- pieces: neighbouring cells in (viewing direction, 1 / range), where the sensor's pixels are evenly spaced
  and its depth noise is the same everywhere (sigma(1/r) = noise at 1 m), so one cell size serves 0.5-5 m;
  only pieces where ``INLIER_SIGMAS`` of the noise exceed the search's threshold (nearer, the search's own
  verdict stands) and no wider than an object;
- a *capped* cylinder (``capped_residuals``): a standing cylinder seen from above shows its top as much as
  its side, and a side-only fit bends to take the top in. Axes from the piece's normals and its spread, an
  algebraic circle across each, then a robust least-squares fit of all seven parameters (axis, position,
  radius, both ends) on the errors along the rays, refit on the points within ``INLIER_SIGMAS``. Each axis
  is tried twice: started on all the piece's points, and on those inside its outline (``silhouette``): the
  flying pixels along a far object's outline (10-20 % of its piece) pull a fit started among them to a
  radius of 9-34 cm, and the silhouette points that do lie on the object are what fixes a far radius;
- the verdict is model selection, not a looser threshold: the best cylinder must explain ``MIN_EXPLAINED`` of
  the piece with errors the size of the noise (``MAX_MEDIAN``), and no rival may cost within
  ``AMBIGUOUS_COST`` of it (``truncated_cost``): a sphere in the radius range, a cylinder of another radius
  from another axis, or a box (``box_cost``, started at several turns about each axis: boxes are what a far
  capped cylinder is most often confused with, and a box fit started at one turn stops at a box turned
  across the true one). The detector's own arc, length and inside checks then judge the side's inliers at
  the noise's threshold; its normal checks do not (far normals turn 0.3-0.75 degrees per degree on real
  cylinders);
- a piece's cylinder that lies on the points of an object already found (``MAX_SHARED``) is that object seen
  again: the top, rim and flying pixels a search's fit leaves behind made a second cylinder of one object.

The fits are the pass's cost, so each is lean: the errors of K solids in one NumPy call (``ray_residuals``),
forward-difference Jacobians of all parameters in one call (``forward_jacobian``), a Levenberg-Marquardt of
little overhead (``robust_fit``), and the rivals (sphere, box) fitted only for a cylinder that the caller's
cheaper verdicts (an object already found, the detector's checks) let through: 3.5-4x less CPU than scipy's
trust region with one call per parameter, the same detections on the scenes below.

Measured on the fresh table scenes (tests/objrec3d/test_3d_small_far.py, 114 objects with 300 or more
visible points): with the pass 97 found organized and 102 unorganized, without it 87 and 90; beyond 2 m 26
of 36 against 16; no false object on either path.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .box_rival import BOX_PENALTY, BOX_POINTS, box_cost
from .fitting import ShapeFit
from .ray_residuals import (
    INLIER_SIGMAS,
    RayPoints,
    basis,
    capped_residuals_batch,
    front_residuals,
    sphere_residuals_batch,
    truncated_cost,
    unit,
)
from .robust_fit import robust_least_squares
from .silhouette import inside_outline
from .vec import dot3

log = logging.getLogger(__name__)

#: A fit must explain this share of its piece's points (the rest: flying pixels at the rim, a cylinder's caps).
MIN_EXPLAINED = 0.5
#: A fit's median error must stay within this many sigmas (0.67 for pure noise).
MAX_MEDIAN = 0.9
#: A rival model whose ``truncated_cost`` is within this of the best makes the piece ambiguous (no object) ...
AMBIGUOUS_COST = 9.0
#: ... when its radius differs by more than this share.
AMBIGUOUS_RADIUS = 0.1
#: A cylinder's visible side is about as wide as its radius (2 x the spread across the axis: 0.6-1.0 r on
#: cylinders beyond 1.5 m); a box's edge fitted by a large arc is a narrow strip (0.2-0.35 r).
MIN_WIDTH = 0.5
#: Cells of the pieces: this many pixels' worth of viewing angle (``PIXEL_ANGLE``) and this many sigmas of 1/range.
CELL_PIXELS = 2.5
CELL_SIGMAS = 3.0
#: A VGA depth camera's angle per pixel (525 px focal length): the pieces' lateral cell.
PIXEL_ANGLE = 1.0 / 525.0
#: A piece of more points than this is the search's to judge: every object of the fresh table scenes with 1,500
#: visible points is found by it (tests/objrec3d/test_3d_small_far.py). Bounds the pass's work per piece.
MAX_PIECE_POINTS = 3000
#: The largest pieces first, at most this many a frame (a far table scene leaves 2-8 of a plausible size):
#: bounds the pass's work on clutter.
MAX_PIECES = 12
#: Rounds of the robust fits at most (refit on the inliers of the last fit); a fit stops sooner when a round's
#: inliers are the ones it was fitted on (the next round would start at its own optimum).
ROUNDS = 4
#: A round of a cylinder fit stops when its cost or its parameters change by less than this share (a tenth of
#: a millimetre on a 4 cm radius; scipy's default, 1e-8, spends most of a round polishing noise).
FIT_TOLERANCE = 1e-3
#: The sphere and box rivals' fits stop at scipy's default tolerance (their evaluations are bounded instead): a
#: rival's cost is compared with the cylinder's, so it is fitted to the end.
RIVAL_TOLERANCE = 1e-8


@dataclass(frozen=True)
class ClusterSettings:
    """What the pass looks for: the radius range, the depth noise at 1 m, the sensor, the fewest inliers."""

    noise: float
    min_radius: float
    max_radius: float
    min_inliers: int
    sensor: np.ndarray
    #: The search's distance threshold: pieces where the noise is within it are left alone.
    threshold: float


def depth_sigma(points: np.ndarray, sensor: np.ndarray, noise: float) -> np.ndarray:
    """The depth noise (sigma, metres) at each point's range: ``noise`` x range^2."""
    rel = points - sensor
    return noise * np.einsum("ij,ij->i", rel, rel)


def pieces(points: np.ndarray, sensor: np.ndarray, noise: float) -> list[np.ndarray]:
    """Indices of the connected pieces of ``points``: neighbouring cells in (direction, 1 / range)."""
    if points.shape[0] == 0:
        return []
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rel = points - sensor
    rng = np.maximum(np.linalg.norm(rel, axis=1), 1e-9)
    coords = np.concatenate([rel / rng[:, None] / (CELL_PIXELS * PIXEL_ANGLE),
                             (1.0 / rng / (CELL_SIGMAS * max(noise, 1e-6)))[:, None]], axis=1)
    keys = np.floor(coords).astype(np.int64)
    keys -= keys.min(axis=0) - 1
    span = keys.max(axis=0) + 2
    flat = np.zeros(keys.shape[0], dtype=np.int64)
    for d in range(4):
        flat = flat * span[d] + keys[:, d]
    cells, inverse = np.unique(flat, return_inverse=True)
    inverse = inverse.reshape(-1)
    strides = np.array([span[1] * span[2] * span[3], span[2] * span[3], span[3], 1], dtype=np.int64)
    rows, cols = [], []
    for offset in np.array(np.meshgrid(*[(-1, 0, 1)] * 4, indexing="ij")).reshape(4, -1).T:
        shift = int(offset @ strides)
        if shift <= 0:
            continue  # each neighbour pair once
        at = np.searchsorted(cells, cells + shift)
        at[at == cells.size] = 0
        hit = cells[at] == cells + shift
        rows.append(np.flatnonzero(hit))
        cols.append(at[hit])
    row, col = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(row.size, dtype=np.int8), (row, col)), shape=(cells.size, cells.size))
    _, label = connected_components(graph, directed=False)
    point_label = label[inverse]
    order = np.argsort(point_label, kind="stable")
    bounds = np.flatnonzero(np.diff(point_label[order])) + 1
    return np.split(order, bounds)


def _algebraic(pts: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Circle (2D) or sphere (3D) by linear least squares: |p|^2 = 2 c.p + d (Kasa)."""
    design = np.concatenate([2.0 * pts, np.ones((pts.shape[0], 1))], axis=1)
    try:
        solution, *_ = np.linalg.lstsq(design, np.einsum("ij,ij->i", pts, pts), rcond=None)
    except np.linalg.LinAlgError:
        return None
    center = solution[:-1]
    squared = solution[-1] + center @ center
    return (center, math.sqrt(squared)) if squared > 0 else None


def fit_sphere(pts: np.ndarray, rays: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, float, np.ndarray] | None:
    """A sphere by its points' errors along their rays (``front_residuals``): algebraic start, robust least
    squares refit on the inliers until they repeat. Centre, radius, and each point's error in sigmas."""
    start = _algebraic(pts)
    if start is None:
        return None
    x = np.append(start[0], start[1])
    keep = np.ones(pts.shape[0], dtype=bool)
    for _ in range(ROUNDS):
        if keep.sum() < 8:
            return None

        def weighted(xs: np.ndarray, keep: np.ndarray = keep) -> np.ndarray:
            return sphere_residuals_batch(pts[keep], rays[keep], xs[:, :3], xs[:, 3]) / sigma[keep]

        x, _ = robust_least_squares(weighted, x, max_nfev=60, ftol=RIVAL_TOLERANCE, xtol=RIVAL_TOLERANCE)
        if not np.isfinite(x).all() or x[3] <= 0:
            return None
        fitted_on, keep = keep, np.abs(front_residuals(pts, rays, x[:3], x[3])) < INLIER_SIGMAS * sigma
        if np.array_equal(keep, fitted_on):
            break  # the next round would fit the same points from this optimum
    return x[:3], float(x[3]), front_residuals(pts, rays, x[:3], x[3]) / sigma


@dataclass(frozen=True)
class CappedParameters:
    """A capped cylinder's seven parameters near a start axis ``axis0``: x = (axis tilt along ``u``, ``v``;
    centre offset from ``base`` along ``u``, ``v``; radius; ends along the axis from the centre)."""

    base: np.ndarray
    axis0: np.ndarray
    u: np.ndarray
    v: np.ndarray

    def solids(self, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """K parameter vectors (K x 7) as the arguments of ``capped_residuals_batch``."""
        axis = unit(self.axis0 + xs[:, 0, None] * self.u + xs[:, 1, None] * self.v)
        return axis, self.base + xs[:, 2, None] * self.u + xs[:, 3, None] * self.v, xs[:, 4], xs[:, 5], xs[:, 6]

    def errors(self, seen: RayPoints, sigma: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """The errors in sigmas of the points ``seen`` as a function of K parameter vectors (K x N)."""
        return lambda xs: capped_residuals_batch(seen, *self.solids(xs))[0] / sigma


def fit_cylinder(pts: np.ndarray, rays: np.ndarray, sigma: np.ndarray, axis0: np.ndarray, sensor: np.ndarray,
                 start_on: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray] | None:
    """A capped cylinder near ``axis0`` by its points' errors along their rays (``capped_residuals``; robust
    least squares of all seven parameters, refit on the inliers of all points, until they repeat). The first
    fit uses the points ``start_on`` (a mask; all by default: the points inside the outline keep flying pixels
    out of it). The centre (mid-way between the ends), axis, radius, each point's error in sigmas, and which
    points lie on the side."""
    keep = np.ones(pts.shape[0], dtype=bool) if start_on is None else start_on.copy()
    if keep.sum() < 12:
        return None
    u, v = basis(axis0)
    seen = RayPoints.of(pts, rays, sensor)
    base = pts[keep].mean(axis=0)
    frame = CappedParameters(base, axis0, u, v)
    rel = pts[keep] - base
    start = _algebraic(np.stack([dot3(rel, u), dot3(rel, v)], axis=1))
    if start is None:
        return None
    (cu, cv), radius = start
    along = dot3(rel, axis0)
    x = np.array([0.0, 0.0, cu, cv, radius, *np.percentile(along, [1.0, 99.0])])
    for _ in range(ROUNDS):
        if keep.sum() < 12:
            return None
        x, _ = robust_least_squares(frame.errors(seen.subset(keep), sigma[keep]), x, max_nfev=80,
                                    ftol=FIT_TOLERANCE, xtol=FIT_TOLERANCE)
        if not np.isfinite(x).all() or x[4] <= 0:
            return None
        fitted_on, keep = keep, np.abs(frame.errors(seen, sigma)(x[None])[0]) < INLIER_SIGMAS
        if np.array_equal(keep, fitted_on):
            break  # the next round would fit the same points from this optimum
    solid = frame.solids(x[None])
    residual, side = (part[0] for part in capped_residuals_batch(seen, *solid))
    axis, center, radius, low, high = (part[0] for part in solid)
    return center + 0.5 * (low + high) * axis, axis, float(radius), residual / sigma, side


def axis_candidates(pts: np.ndarray, nrm: np.ndarray) -> list[np.ndarray]:
    """Where a piece's cylinder axis may point: the direction its normals are all perpendicular to, and its
    longest and shortest spreads (a long cylinder lies along its points; a short one seen end on across)."""
    _, by_normals = np.linalg.eigh(np.einsum("ni,nj->ij", nrm, nrm))
    rel = pts - pts.mean(axis=0)
    _, by_spread = np.linalg.eigh(np.einsum("ni,nj->ij", rel, rel))
    out: list[np.ndarray] = []
    for axis in (by_normals[:, 0], by_spread[:, 2], by_spread[:, 0]):
        if all(abs(axis @ other) < math.cos(math.radians(10.0)) for other in out):
            out.append(axis)
    return out


def fit_piece(pts: np.ndarray, nrm: np.ndarray, settings: ClusterSettings,
              refuse: Callable[[ShapeFit], bool] | None = None) -> ShapeFit | None:
    """The cylinder that explains a piece, its inliers indexing ``pts``; None when none does unambiguously:
    fewer than ``MIN_EXPLAINED`` of the piece within ``INLIER_SIGMAS``, errors wider than the noise
    (``MAX_MEDIAN``), a rival that costs less than ``AMBIGUOUS_COST`` more (a sphere in the radius range, or a
    cylinder from another axis with another radius), or a piece narrower than the cylinder it would be
    (``MIN_WIDTH``: a box's edge). ``refuse``, the caller's own verdict on the best cylinder (its side's
    inliers), is asked before the sphere and box rivals are fitted: they cost as much as the cylinder's fits,
    and a cylinder the caller refuses anyway (an object already found, seen again) needs no rival."""
    rays = unit(pts - settings.sensor)
    sigma = np.maximum(depth_sigma(pts, settings.sensor, settings.noise), 1e-4)
    fits: list[tuple[float, ShapeFit]] = []
    sides: dict[int, np.ndarray] = {}  # per fit: its inliers on the side (not an end)
    errors: dict[int, np.ndarray] = {}  # per fit: its points' errors in sigmas
    inside = inside_outline(pts, settings.sensor, PIXEL_ANGLE)
    starts = [(axis0, None) for axis0 in axis_candidates(pts, nrm)]
    if MIN_EXPLAINED * pts.shape[0] <= inside.sum() < pts.shape[0]:  # started away from the flying pixels too
        starts += [(axis0, inside) for axis0 in axis_candidates(pts[inside], nrm[inside])]
    for axis0, start_on in starts:
        cylinder = fit_cylinder(pts, rays, sigma, axis0, settings.sensor, start_on)
        if cylinder is None:
            continue
        error = np.abs(cylinder[3])
        fit = ShapeFit("cylinder", cylinder[0], cylinder[1], cylinder[2], np.flatnonzero(error < INLIER_SIGMAS),
                       float(np.median(error)))
        sides[id(fit)] = np.flatnonzero((error < INLIER_SIGMAS) & cylinder[4])
        errors[id(fit)] = error
        fits.append((truncated_cost(error), fit))
    if not fits:
        return None
    fits.sort(key=lambda f: f[0])
    cost, best = fits[0]
    best_error = errors[id(best)]
    share = best.inliers.size / pts.shape[0]
    if not settings.min_radius <= best.radius <= settings.max_radius:
        log.debug("piece of %d: radius %.4f out of range", pts.shape[0], best.radius)
        return None
    if share < MIN_EXPLAINED or best.cost > MAX_MEDIAN or best.inliers.size < settings.min_inliers:
        log.debug("piece of %d: r=%.4f explains %.2f, median %.2f sigmas", pts.shape[0], best.radius, share,
                  best.cost)
        return None
    if any(other < cost + AMBIGUOUS_COST and abs(fit.radius - best.radius) > AMBIGUOUS_RADIUS * best.radius
           for other, fit in fits[1:]):
        log.debug("piece of %d: r=%.4f ambiguous: %s", pts.shape[0], best.radius,
                  [(round(f.radius, 4), round(c - cost, 1)) for c, f in fits])
        return None
    rel = pts - pts.mean(axis=0)
    rel -= dot3(rel, best.axis)[:, None] * best.axis
    width = 2.0 * float(np.sqrt(np.linalg.eigvalsh(np.einsum("ni,nj->ij", rel, rel))[-1] / pts.shape[0]))
    if width < MIN_WIDTH * best.radius:
        log.debug("piece of %d: r=%.4f but %.3f m wide", pts.shape[0], best.radius, width)
        return None
    best.inliers = sides[id(best)]  # what the detector's checks look at: the side, not the ends
    if refuse is not None and refuse(best):
        return None
    sphere = fit_sphere(pts, rays, sigma)
    sphere_cost = math.inf if sphere is None else truncated_cost(sphere[2])
    if sphere is not None and settings.min_radius <= sphere[1] <= settings.max_radius and (
            sphere_cost < cost + AMBIGUOUS_COST):
        log.debug("piece of %d: r=%.4f, but a sphere r=%.4f costs %.1f more", pts.shape[0], best.radius, sphere[1],
                  truncated_cost(sphere[2]) - cost)
        return None
    thin = np.arange(0, pts.shape[0], math.ceil(pts.shape[0] / BOX_POINTS))
    scale = pts.shape[0] / thin.size  # the thinned cost's difference, as on the whole piece
    boxed = cost + scale * (box_cost(pts[thin], rays[thin], sigma[thin], best.axis, settings.sensor)
                            - truncated_cost(best_error[thin]))
    if boxed < cost + AMBIGUOUS_COST - BOX_PENALTY:
        log.debug("piece of %d: r=%.4f, but a box costs %.1f more", pts.shape[0], best.radius, boxed - cost)
        return None
    log.debug("piece of %d: r=%.4f explains %.2f, median %.2f; box +%.1f, sphere +%.1f, cylinders %s", pts.shape[0],
              best.radius, share, best.cost, boxed - cost, sphere_cost - cost,
              [(round(f.radius, 4), round(c - cost, 1)) for c, f in fits[1:]])
    return best


#: A piece's cylinder whose surface passes through more points of the objects already found than this share of
#: its own inliers is one of them seen again: the rim, top or flying pixels the search's fit left behind.
MAX_SHARED = 0.5


def _shared(fit: ShapeFit, points: np.ndarray, taken: np.ndarray, settings: ClusterSettings) -> int:
    """How many ``taken`` points (a mask) lie on the fitted cylinder's side within ``INLIER_SIGMAS`` of the depth
    noise at their range, between its inliers' ends."""
    index = np.flatnonzero(taken)
    if index.size == 0 or fit.axis is None:
        return 0
    reach = dot3(points[fit.inliers] - fit.center, fit.axis)
    rel = points[index] - fit.center
    along = dot3(rel, fit.axis)
    across = np.linalg.norm(rel - along[:, None] * fit.axis, axis=1)
    sigma = depth_sigma(points[index], settings.sensor, settings.noise)
    on = (np.abs(across - fit.radius) < INLIER_SIGMAS * sigma) & (along >= reach.min()) & (along <= reach.max())
    return int(on.sum())


def cluster_fits(points: np.ndarray, normals: np.ndarray, free: np.ndarray, settings: ClusterSettings,
                 judge: Callable[[ShapeFit, float], str | None]) -> list[ShapeFit]:
    """The cylinder fits of the pieces of the ``free`` points (a mask over ``points``) that lie where the
    depth noise exceeds the search's threshold and that ``judge`` accepts (given the fit, its inliers indexing
    ``points``, and the threshold of the noise at its range), most inliers first."""
    index = np.flatnonzero(free)
    out: list[ShapeFit] = []
    if not (INLIER_SIGMAS * depth_sigma(points[index], settings.sensor, settings.noise) >= settings.threshold).any():
        return out  # every piece's middle is nearer than its farthest point: the search's threshold holds there
    plausible = [piece for piece in pieces(points[index], settings.sensor, settings.noise)
                 if settings.min_inliers <= piece.size <= MAX_PIECE_POINTS]
    plausible.sort(key=lambda piece: -piece.size)
    if len(plausible) > MAX_PIECES:
        log.debug("%d pieces: the %d largest fitted", len(plausible), MAX_PIECES)
    for piece in plausible[:MAX_PIECES]:
        chosen = index[piece]
        pts = points[chosen]
        middle = pts.mean(axis=0)
        at = INLIER_SIGMAS * float(depth_sigma(middle[None], settings.sensor, settings.noise)[0])
        if at < settings.threshold:
            continue  # the search's own threshold holds there: what it left is no object
        rel = pts - middle
        extent = np.sqrt(np.linalg.eigvalsh(np.einsum("ni,nj->ij", rel, rel)) / pts.shape[0])
        if 2.0 * extent[1] > 2.0 * settings.max_radius:  # a piece wider than any object: a wall, a merge
            continue
        judged: list[ShapeFit] = []

        def refuse(fit: ShapeFit, chosen: np.ndarray = chosen, at: float = at, judged: list[ShapeFit] = judged
                   ) -> bool:
            """The checks of the whole cloud, before the piece's rivals: an object already found, or the
            detector's verdict. The fit judged (its inliers indexing ``points``) is kept in ``judged``."""
            fit = dataclasses.replace(fit, inliers=chosen[fit.inliers])
            shared = _shared(fit, points, ~free, settings)
            if shared > MAX_SHARED * fit.inliers.size:  # an object the search found, seen again (its rim or top)
                log.debug("piece of %d: cylinder r=%.4f lies on %d points of found objects", chosen.size,
                          fit.radius, shared)
                return True
            verdict = judge(fit, at)
            log.debug("piece of %d: cylinder r=%.4f: %s", chosen.size, fit.radius, verdict or "passes the checks")
            judged.append(fit)
            return verdict is not None

        if fit_piece(pts, normals[chosen], settings, refuse) is not None:
            log.debug("piece of %d: cylinder r=%.4f accepted", pts.shape[0], judged[0].radius)
            out.append(judged[0])
    out.sort(key=lambda f: -f.inliers.size)
    return out
