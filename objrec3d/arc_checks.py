"""Is a fitted cylinder a round surface, or the rounded edge of a flat-sided object? The profile of its visible arc.

A cylinder hypothesis drawn from two points with normals on a box's rounded (or sharp) edge fits the edge
well: its inliers alone look like a short arc, and every check on them passes at its limits. What gives the
edge away is the rest of the surface the camera sees around that arc: the faces go on where a round object
would keep turning. So the checks here look at the whole *visible arc window*: the points within the
inliers' reach along the axis, near the fitted surface (``WINDOW_BAND``), facing outward, and within
``WINDOW_DEGREES`` of the direction to the sensor in the cross-section (where a round object shows itself;
closer to the silhouette the normals are smoothed across it and stereo depth bleeds). There:

- the normals must *turn with the arc*: their angle in the cross-section, regressed on the position angle
  (per-bin medians), has a slope near 1 on a cylinder and near 0 on a flat face (a face plus a rounded edge lies
  between: 0.1-0.9 on box edges, 0.66 on the milk scan's flat-sided bottle; real cylinders 0.74-1.01);
- the normals must *agree with the fitted surface's* (within ``AGREEMENT_DEGREES``) nearly everywhere on
  the window: 85-100 % on real cylinders, 38-78 % on box edges;
- the radial residuals across the arc must be a *band without a parabola*: a flat face leaves the fitted
  circle tangentially, a systematic sag that a quadratic in the arc angle picks up; its size at the window's
  ends, in units of the residuals' own noise, is -1.9 to 0.6 on real cylinders (depth noise included) and up
  to 6 on flat-sided objects (5.1 on the milk scan's bottle);
- the normals must turn *evenly* (the ``wave``): a box whose vertical edges are rounded shows flat stretches whose
  normals do not turn, joined by short fast turns, so the normals' departure from the fitted surface's, per bin,
  swings back and forth across the arc (a wave of 4-11 degrees on 5-12 cm faces with 1-3 cm edges at 0.6-2 m)
  where a round surface's stays on one straight line (the bins' own noise taken off: at most 3.8 degrees on
  the fresh-table cylinders, 3.5 on the benchmark's, 2.0 on the mug and Clorox scans). Where the edge radius is
  half the face, the end *is* a half cylinder: nothing in its arc tells it from a round object.

"Real cylinders": the several-shape benchmark's synthetic scenes at 0.5-2.5 m (neighbours touching them
included), the fresh-table sensor model at 0.8-2.5 m, the mug and Clorox scans; "box edges": boxes of 12-20 cm
with sharp and rounded edges at 0.8-2.5 m (tests/objrec3d/test_3d_flat_sided.py), and of 5-12 cm with 1-3 cm
edges at 0.6-2 m (tests/objrec3d/test_3d_arc_checks_wave.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .fitting import ShapeFit
from .vec import cross3, dot3

#: Half-width of the window around the direction to the sensor, degrees. A camera sees a cylinder's arc up to
#: 90 degrees either side; beyond 70 the normals are smoothed across the silhouette (the mug scan's stereo depth
#: turned the turn slope from 0.91 to 0.79 and the sag from 0.9 to 3.4 noise units when the window reached 85).
WINDOW_DEGREES = 70.0
#: Points this near the fitted surface belong to the window: the larger of this many distance thresholds and
#: ``WINDOW_RADIUS_SHARE`` of the radius, so that a face leaving the circle tangentially stays in it for tens
#: of degrees past the inliers (it is those points that give the face away).
WINDOW_THRESHOLDS = 2.0
WINDOW_RADIUS_SHARE = 0.25
#: A window point whose normal is turned more than this from the fitted surface's is another surface (a neighbour's
#: side at 45-100 degrees on the demo scenes), not a face continuing the arc (a tangent face within the window
#: turns up to about 35 degrees before it leaves the band).
CONTINUATION_DEGREES = 40.0
#: A normal agrees with the fitted surface within this many degrees (the inlier cost allows about 11 degrees
#: at zero distance with the default weight; 15 leaves room for a far object's normal noise).
AGREEMENT_DEGREES = 15.0
#: The residuals' noise (robust sigma) is floored at this share of the distance threshold, so that a clean
#: synthetic cylinder's numerical sag is not divided by zero.
NOISE_FLOOR_SHARE = 0.05
#: At most about this many window points are looked at (evenly thinned): a bin's median needs no more.
WINDOW_POINTS = 3000
#: Fewer window points than this say nothing: the checks pass.
MIN_WINDOW_POINTS = 12
#: A window point's normal must lie within 45 degrees of the cross-section (its length there at least this).
MIN_ACROSS = math.cos(math.radians(45.0))
#: The turn and the sag are fitted to the medians of bins this many degrees of arc wide, of at least
#: ``MIN_BIN_POINTS`` points each (at least three bins, or the checks pass).
BIN_DEGREES = 10.0
MIN_BIN_POINTS = 3
#: The wave is measured on the bins within this many degrees of the direction to the sensor: nearer the
#: silhouette a real cylinder's smoothed normals bend toward the sensor (on small and far cylinders by up to
#: 10 degrees at 55-65), a pattern of their own that is no flat stretch.
WAVE_DEGREES = 50.0
#: Fewer bins than this within ``WAVE_DEGREES`` say nothing about the wave (it is 0).
MIN_WAVE_BINS = 4
#: The bins' own noise taken off the wave: this many standard errors of a bin's median (the median of n normals
#: of robust spread s has a standard error of about 1.25 s / sqrt(n)).
WAVE_NOISE_ERRORS = 2.0


@dataclass(frozen=True)
class ArcProfile:
    """How a cylinder's visible arc window looks: see the module's docstring."""

    points: int  # in the window
    turn: float  # slope of the normals' angle against the position angle (1 on a cylinder)
    agreement: float  # share of the window's normals within AGREEMENT_DEGREES of the fitted surface's
    sag: float  # the quadratic's departure at the window's ends, in units of the residuals' noise (signed)
    sag_metres: float  # the same in metres
    wave: float = 0.0  # degrees: how unevenly the normals turn (their departure's spread about a straight line)


def arc_profile(fit: ShapeFit, points: np.ndarray, normals: np.ndarray, threshold: float,
                sensor: np.ndarray | None = None) -> ArcProfile | None:
    """The profile of a cylinder fit's visible arc window among ``points`` (those ``fit.inliers`` index), or
    None for a sphere or a window of fewer than ``MIN_WINDOW_POINTS`` points."""
    if fit.axis is None or fit.inliers.size == 0:
        return None
    axis = fit.axis
    rel = points - fit.center
    along = dot3(rel, axis)
    reach = along[fit.inliers]
    toward = (np.zeros(3) if sensor is None else np.asarray(sensor, dtype=np.float64)) - fit.center
    toward = toward - (toward @ axis) * axis
    if np.linalg.norm(toward) < 1e-9:  # looking straight along the axis: there is no arc to see
        return None
    u = toward / np.linalg.norm(toward)
    v = cross3(axis, u)
    x, y = dot3(rel, u), dot3(rel, v)
    dist = np.hypot(x, y)
    # |angle from the sensor's direction| < WINDOW_DEGREES, as x >= cos * dist: no angle for every point.
    window = ((along >= reach.min()) & (along <= reach.max())
              & (np.abs(dist - fit.radius) < max(WINDOW_THRESHOLDS * threshold, WINDOW_RADIUS_SHARE * fit.radius))
              & (x > math.cos(math.radians(WINDOW_DEGREES)) * dist))
    index = np.flatnonzero(window)
    index = index[:: max(1, index.size // WINDOW_POINTS)]  # evenly thinned: medians and shares need no more
    x, y, dist = x[index], y[index], dist[index]
    nx, ny = dot3(normals[index], u), dot3(normals[index], v)
    # Facing outward, and turned toward the cross-section: a standing cylinder's cap (normals along the axis)
    # reaches the surface at its rim, and its normals' direction in the cross-section is noise.
    across = nx * nx + ny * ny
    keep = (nx * x + ny * y > 0) & (across > MIN_ACROSS * MIN_ACROSS)
    at = np.arctan2(y[keep], x[keep])
    facing = np.arctan2(ny[keep], nx[keep])
    residual = dist[keep] - fit.radius
    departure = (facing - at + math.pi) % (2.0 * math.pi) - math.pi  # signed: the wave needs its sign
    off = np.abs(departure)
    # A face continuing the arc turns away from the fitted surface's normal gradually, a neighbouring object's
    # surface (a sphere against the cylinder, the next can) at once and by more: leave the latter out.
    same = off < math.radians(CONTINUATION_DEGREES)
    at, facing, residual, off, departure = at[same], facing[same], residual[same], off[same], departure[same]
    count = int(same.sum())
    if count < MIN_WINDOW_POINTS:
        return None
    agreement = float(np.mean(off < math.radians(AGREEMENT_DEGREES)))
    # Per bin of the arc angle, the medians: another object's points in the window (a neighbour's side, flying
    # pixels) move a bin's median little and a least-squares fit through every point much.
    # 8-bit bin numbers (37 at most): NumPy sorts them by counting, stably, in one pass.
    bins = np.floor((at + math.pi) / math.radians(BIN_DEGREES)).astype(np.uint8)
    order = np.argsort(bins, kind="stable")
    counts = np.bincount(bins)
    sizes = counts[counts > 0]
    starts = np.cumsum(sizes) - sizes
    full = sizes >= MIN_BIN_POINTS
    if full.sum() < 3:
        return None
    mid_at, mid_facing, mid_residual = (_bin_medians(bins, values, starts[full], sizes[full])
                                        for values in (at, facing, residual))
    weight = np.sqrt(sizes[full].astype(np.float64))
    # The turn: the weighted least-squares slope of the normals' angle on the position angle.
    centred = mid_at - np.average(mid_at, weights=weight)
    spread = float(np.sum(weight * centred * centred))
    turn = float(np.sum(weight * centred * (mid_facing - np.average(mid_facing, weights=weight))) / spread
                 ) if spread > 1e-12 else 1.0
    # The sag: a quadratic in the arc angle through the bins' residuals, its curvature times the half-span
    # squared; the noise: the points' robust spread about their bin's median.
    design = np.stack([np.ones_like(mid_at), mid_at, mid_at * mid_at], axis=1) * weight[:, None]
    coefficients, *_ = np.linalg.lstsq(design, mid_residual * weight, rcond=None)
    in_full = np.repeat(full, sizes)
    spread_about = residual[order][in_full] - np.repeat(mid_residual, sizes[full])
    noise = max(1.4826 * float(np.median(np.abs(spread_about))), NOISE_FLOOR_SHARE * threshold)
    half = 0.5 * float(mid_at.max() - mid_at.min())
    sag = float(coefficients[2]) * half * half
    wave = _wave(bins, departure, mid_at, starts[full], sizes[full])
    return ArcProfile(count, turn, agreement, sag / noise, sag, wave)


def _wave(bins: np.ndarray, departure: np.ndarray, mid_at: np.ndarray, starts: np.ndarray, sizes: np.ndarray
          ) -> float:
    """How unevenly the normals turn, degrees: the per-bin medians of the normals' signed ``departure`` from the
    fitted surface's, within ``WAVE_DEGREES`` of the sensor's direction, about their weighted straight line in
    the arc angle (a turn other than 1 is such a line, and ``min_turn``'s to judge), less the bins' own noise.

    A round surface leaves a band about the line; a rounded box a swing (a flat stretch's normals lag behind
    the arc, the rounded edge's catch up), which no straight line takes out."""
    ordered = departure[by_bin_and_value(bins, departure)]
    mid_departure = _lower_middles(ordered, starts, sizes)  # the bins' medians, from the sort needed below anyway
    # Each bin's median absolute deviation from its median, all bins in one sort (np.median's value: the middle
    # one, or the mean of the two middle ones).
    member = np.repeat(np.arange(sizes.size, dtype=np.uint8), sizes)
    first = np.cumsum(sizes) - sizes  # where each bin starts among the members
    within = np.arange(member.size) - np.repeat(first, sizes)
    deviation = np.abs(ordered[np.repeat(starts, sizes) + within] - np.repeat(mid_departure, sizes))
    deviation = deviation[by_bin_and_value(member, deviation)]
    spread = 1.4826 * ((deviation[first + (sizes - 1) // 2] + deviation[first + sizes // 2]) / 2.0)
    inner = np.abs(mid_at) <= math.radians(WAVE_DEGREES)
    if inner.sum() < MIN_WAVE_BINS:
        return 0.0
    x, y, n, spread = mid_at[inner], mid_departure[inner], sizes[inner].astype(np.float64), spread[inner]
    weight = np.sqrt(n)
    design = np.stack([np.ones_like(x), x], axis=1) * weight[:, None]
    coefficients, *_ = np.linalg.lstsq(design, y * weight, rcond=None)
    left = y - coefficients[0] - coefficients[1] * x
    squared = float(np.sum(n * left * left) / np.sum(n))
    errors = float(np.mean((1.2533 * spread) ** 2 / n))
    return math.degrees(math.sqrt(max(0.0, squared - WAVE_NOISE_ERRORS**2 * errors)))


def _bin_medians(bins: np.ndarray, values: np.ndarray, starts: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """The (lower) median of ``values`` in each bin that starts at ``starts`` (and holds ``sizes``) in the
    order of the sorted bins: one sort by bin and value, no median per bin."""
    return _lower_middles(values[by_bin_and_value(bins, values)], starts, sizes)


def _lower_middles(ordered: np.ndarray, starts: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Per bin of ``ordered`` (sorted by bin and value), its lower middle value: the bin's (lower) median."""
    return ordered[starts + (sizes - 1) // 2]


def by_bin_and_value(bins: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The order of ``np.lexsort((values, bins))`` up to ties of equal values (which give the same medians): by
    value, then stably by bin. For 8-bit ``bins`` the second sort is NumPy's counting sort; together a quarter
    of lexsort's time on a visible arc's 1,500 points, and the profile takes five such sorts."""
    by_value = np.argsort(values)
    return by_value[np.argsort(bins[by_value], kind="stable")]
