"""Is a RANSAC plane a plane? The checks PlaneRemovalFilter makes before it removes one.

RANSAC's plane is a slab: every point within the threshold of it, wherever it lies. When fewer real planes are
in view than the filter is asked to remove, the largest slab left is an object's own face (the front of a
mug, a 2 cm strip tangent to a big cylinder), and removing it loses the object. So the slab is split into
patches, pieces connected in the plane, and a patch is taken only when it is a plane:

- flat: most of its points' normals agree with the plane's (a curved wall tangent to the slab does not);
- large against the objects sought: narrowest across at least a given size (an object's face is not);
- not better explained by a cylinder or sphere of the radius range sought: its normals do not turn across it
  as a surface of such a radius does (curvature from a least-squares fit of the normals against position).

The patches are found and judged on a sample of the slab (a few thousand points; normals from a coarse grid
of an organized cloud, or at a random sample of an unorganized one): the checks must cost a few milliseconds
per plane where the detector after them spends a hundred or more. A slab whose patches are all planes goes
whole, as before the checks; only when some are and some are not is every point sorted into its patch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .cloud import PointCloud
from .normals import grid_normals, knn_normals
from .vec import dot3, pair_dots

#: An organized cloud's normals for the checks are estimated every this many pixels of a 640-pixel-wide image
#: (proportionally fewer for smaller images): coarse, and a sixteenth the cost.
_GRID_STEP_AT_VGA = 4
#: Half-size of the coarse grid's normal box, in coarse pixels (5 x 5 of them, 20 pixels at VGA): a wall 4-5 m
#: away has noisy depth, and a box of 3 x 3 leaves a third of its normals beyond 20 degrees.
_COARSE_WINDOW = 2
#: Unorganized clouds: this many random points of the cloud get a normal, among this many neighbours.
_NORMALS_SAMPLE = 2000
_NEIGHBOURS_SAMPLE = 8000
#: Patches are connected over cells of this fraction of the largest radius sought (and at least two plane
#: thresholds): gaps narrower than that (an object's shadow, a thin leg) do not split a table.
_CELL_OF_RADIUS = 0.5
#: The dense raster of a slab holds at most this many cells a side; a wider slab gets larger cells.
_MAX_CELLS = 1024
#: A patch is "better explained" by a curved surface when the curvature fit leaves at most this share of the
#: normals' in-plane residual of the flat model.
_CURVED_RESIDUAL = 0.5
#: The checks of a slab look at about this many of its points.
_CHECK_SAMPLE = 3000


class SlabNormals:
    """Normals for the plane checks of one cloud, and which points of a slab the checks look at.

    Organized clouds: the normal of the nearest pixel of a coarse grid, estimated where a check asks, at most
    once per pixel. Unorganized ones: normals at a fixed random sample of the cloud, estimated once among a
    larger sample (one neighbour search per frame, not one per slab); a slab is checked on its points in it.
    """

    def __init__(self, cloud: PointCloud, rng: np.random.Generator) -> None:
        self.cloud = cloud
        self.coarse: PointCloud | None = None  # organized: every step-th pixel of every step-th row
        if cloud.is_organized:
            self.step = max(1, round(_GRID_STEP_AT_VGA * cloud.width / 640))
            grid = np.ascontiguousarray(cloud.grid()[:: self.step, :: self.step])
            self.coarse = PointCloud(grid, sensor_origin=cloud.sensor_origin)
            self.normals = np.full((self.coarse.points.shape[0], 3), np.nan, np.float32)
            self.done = np.zeros(self.coarse.points.shape[0], dtype=bool)
            return
        valid = np.flatnonzero(cloud.valid_mask())
        pick = valid[rng.choice(valid.size, _NEIGHBOURS_SAMPLE, replace=False)] if valid.size > _NEIGHBOURS_SAMPLE \
            else rng.permutation(valid)  # in random order: the first of them get normals
        probe = pick[:_NORMALS_SAMPLE]
        self.slot = np.full(len(cloud), -1, dtype=np.int64)  # per cloud point: its row in self.normals, or -1
        self.slot[probe] = np.arange(probe.size)
        self.normals = knn_normals(cloud.points[pick], 30, cloud.sensor_origin, at=cloud.points[probe])

    def sample(self, slab: np.ndarray) -> np.ndarray:
        """Positions in ``slab`` (indices into the cloud) of the points the checks look at: about
        ``_CHECK_SAMPLE`` spread over it (unorganized: those with a normal)."""
        if self.coarse is not None:
            return np.arange(0, slab.size, max(1, slab.size // _CHECK_SAMPLE))
        return np.flatnonzero(self.slot[slab] >= 0)

    def at(self, indices: np.ndarray) -> np.ndarray:
        """Normals at the points ``indices`` (into the cloud; unorganized: of ``sample``), NaN where none could
        be estimated."""
        if self.coarse is None:
            return self.normals[self.slot[indices]]
        s, gh, gw = self.step, self.coarse.height, self.coarse.width
        rows, cols = np.divmod(indices, self.cloud.width)
        near = np.minimum((rows + s // 2) // s, gh - 1) * gw + np.minimum((cols + s // 2) // s, gw - 1)
        todo = np.unique(near[~self.done[near]])
        if todo.size:
            self.normals[todo] = grid_normals(self.coarse, todo, window=_COARSE_WINDOW)
            self.done[todo] = True
        return self.normals[near]


@dataclass
class Patch:
    """One connected piece of a plane's slab and the verdict on it."""

    size: int  # slab points in the patch (estimated from the sample)
    flat_share: float  # of its sampled points with a normal, those within the angle of the plane's
    extent: float  # metres across its narrower side
    curvature_radius: float  # of its normals' fitted curvature (inf: flat)
    verdict: str  # "" (a plane: removed), or why not

    def describe(self) -> str:
        radius = "flat" if math.isinf(self.curvature_radius) else f"r {self.curvature_radius:.3f} m"
        return (f"{self.size} points, {self.flat_share:.0%} flat, {self.extent:.2f} m across, {radius}"
                f"{': ' + self.verdict if self.verdict else ''}")


@dataclass
class PlaneRules:
    """What a plane must be to be removed (PlaneRemovalFilter's parameters)."""

    normal_angle_deg: float
    min_flat_share: float
    min_extent: float  # metres
    min_points: int
    min_radius: float  # the radius range of the objects sought
    max_radius: float
    threshold: float  # the slab's half-width


@dataclass
class SlabVerdict:
    """A RANSAC slab judged: its patches, and the points to remove (indices into the cloud)."""

    patches: list[Patch]
    remove: np.ndarray


def judge_slab(cloud: PointCloud, slab: np.ndarray, normal: np.ndarray, normals: SlabNormals,
               rules: PlaneRules) -> SlabVerdict:
    """The slab's points (``slab``: indices into the cloud) cut into patches connected in the plane, each
    judged by ``rules``. The patches and checks are made on a sample of a few thousand points; only when some
    patches are planes and others not are all the slab's points sorted into them."""
    axes = np.stack(_plane_axes(normal)).astype(np.float32)
    sample = slab[normals.sample(slab)]
    if sample.size < 3:  # too sparse a sample to judge (an unorganized cloud's small slab): a plane, as before
        return SlabVerdict([Patch(int(slab.size), 1.0, math.inf, math.inf, "")], slab)
    scale = slab.size / max(sample.size, 1)  # slab points per sampled point
    uv = pair_dots(axes, cloud.points[sample])  # 2 x S
    low, high = uv.min(axis=1), uv.max(axis=1)
    cell = max(_CELL_OF_RADIUS * rules.max_radius, 2.0 * rules.threshold,
               float((high - low).max()) / (_MAX_CELLS - 1))
    shape = (int((high[0] - low[0]) / cell) + 1, int((high[1] - low[1]) / cell) + 1)
    cell_of = _cells(uv, low, cell, shape)
    occupied = np.zeros(shape[0] * shape[1], dtype=bool)
    occupied[cell_of] = True
    labels, count = _connected(occupied.reshape(shape))  # per cell: its patch (-1: empty)
    sample_label = labels[cell_of]
    sizes = np.bincount(sample_label, minlength=count) * scale

    sampled = normals.at(sample)
    which = np.flatnonzero(np.isfinite(sampled[:, 0]))
    sampled = sampled[which].astype(np.float64)
    flat = np.abs(dot3(sampled, normal)) >= math.cos(math.radians(rules.normal_angle_deg))
    known_label = sample_label[which]
    known_count = np.bincount(known_label, minlength=count)
    flat_count = np.bincount(known_label, weights=flat, minlength=count)

    patches, taken = [], np.zeros(count, dtype=bool)
    for k in np.flatnonzero(sizes >= min(rules.min_points, slab.size)):
        share = float(flat_count[k] / known_count[k]) if known_count[k] else 1.0
        in_patch = known_label == k
        # Its extent over every sampled point (a floor seen edge-on far away has no normals there), its curvature
        # over those with a normal.
        extent = _narrow_extent(uv[:, sample_label == k].T.astype(np.float64), cell)
        radius = _curvature_radius(uv[:, which[in_patch]].T.astype(np.float64), sampled[in_patch], axes[0], axes[1])
        verdict = ""
        if share < rules.min_flat_share:
            verdict = f"not flat: {share:.0%} of its normals within {rules.normal_angle_deg:g} deg < " \
                      f"{rules.min_flat_share:.0%}"
        elif extent < rules.min_extent:
            verdict = f"{extent:.2f} m across < {rules.min_extent:.2f} m: an object's face"
        elif rules.min_radius * 0.8 <= radius <= rules.max_radius * 1.25:
            verdict = f"its normals turn as a surface of radius {radius:.3f} m: left for the detector"
        taken[k] = not verdict
        patches.append(Patch(int(sizes[k]), share, extent, radius, verdict))
    if not taken.any():
        return SlabVerdict(patches, slab[:0])
    if all(not p.verdict for p in patches):  # planes only (and crumbs too small to judge): the whole slab goes
        return SlabVerdict(patches, slab)
    # Some planes, some not: every point of the slab to its cell. A cell no sampled point fell in goes with a
    # plane next to it.
    planes = (labels >= 0) & taken[labels]
    planes |= _grown(planes.reshape(shape)).reshape(-1) & (labels < 0)
    return SlabVerdict(patches, slab[planes[_cells(pair_dots(axes, cloud.points[slab]), low, cell, shape)]])


#: The eight neighbours of a raster cell, as four offsets and their opposites.
_HALF_NEIGHBOURHOOD = ((0, 1), (1, 0), (1, 1), (1, -1))


def _pairs(grid: np.ndarray, dy: int, dx: int) -> tuple[np.ndarray, np.ndarray]:
    """Views of ``grid`` at each cell and at its neighbour (dy, dx), over the cells that have that neighbour."""
    h, w = grid.shape
    rows, near_rows = slice(0, h - dy), slice(dy, h)
    cols, near_cols = (slice(0, w - dx), slice(dx, w)) if dx >= 0 else (slice(-dx, w), slice(0, w + dx))
    return grid[rows, cols], grid[near_rows, near_cols]


def _connected(occupied: np.ndarray) -> tuple[np.ndarray, int]:
    """8-connected components of a small boolean raster: per cell (flat) its component 0..count-1, -1 where
    empty. Each cell takes the least cell index among its neighbours' labels, then labels jump to their
    label's label, until nothing changes (a few rounds on a slab's raster; no SciPy import, a fifth of a second,
    on a robot's first frame)."""
    flat = occupied.reshape(-1)
    empty = np.iinfo(np.int64).max
    labels = np.where(occupied, np.arange(flat.size).reshape(occupied.shape), empty)
    while True:
        before = labels.copy()
        for dy, dx in _HALF_NEIGHBOURHOOD:  # each cell the least of its own and its neighbours' labels before
            here, there = _pairs(labels, dy, dx)
            old_here, old_there = _pairs(before, dy, dx)
            np.minimum(here, old_there, out=here)
            np.minimum(there, old_here, out=there)
        labels[~occupied] = empty  # an empty cell joins nothing
        line = labels.reshape(-1)
        line[flat] = line[line[flat]]  # jump: a label's own label is never larger
        if np.array_equal(labels, before):
            break
    out = np.full(flat.size, -1, dtype=np.int64)
    roots, out[flat] = np.unique(labels.reshape(-1)[flat], return_inverse=True)
    return out, int(roots.size)


def _grown(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one cell into its eight neighbours."""
    out = mask.copy()
    for dy, dx in _HALF_NEIGHBOURHOOD:
        here, there = _pairs(mask, dy, dx)
        grown_here, grown_there = _pairs(out, dy, dx)
        grown_here |= there
        grown_there |= here
    return out


def _cells(uv: np.ndarray, low: np.ndarray, cell: float, shape: tuple[int, int]) -> np.ndarray:
    """The flat raster cell of each in-plane point (2 x N), clamped to the raster."""
    ij = ((uv - low[:, None]) * np.float32(1.0 / cell)).astype(np.int32)
    np.clip(ij[0], 0, shape[0] - 1, out=ij[0])
    np.clip(ij[1], 0, shape[1] - 1, out=ij[1])
    return ij[0] * shape[1] + ij[1]


def _plane_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane of ``normal``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def _narrow_extent(uv: np.ndarray, cell: float) -> float:
    """The width of points in the plane across their narrower principal direction (5-95 %), plus one cell."""
    centred = uv - uv.mean(axis=0)
    _, vectors = np.linalg.eigh(np.einsum("ni,nj->ij", centred, centred))  # einsum: no threaded BLAS (vec.py)
    across = centred[:, 0] * vectors[0, 0] + centred[:, 1] * vectors[1, 0]
    low, high = np.percentile(across, [5.0, 95.0])
    return float(high - low) / 0.9 + cell


def _curvature_radius(uv: np.ndarray, normals: np.ndarray, u_axis: np.ndarray, v_axis: np.ndarray) -> float:
    """The radius of the surface the normals describe over the patch (inf: flat, or no better than flat).

    A cylinder or sphere of radius r seen along the plane's normal has in-plane normal components that grow
    as (position - centre) / r: a linear fit of the components against position has slope 1 / r (its largest
    eigenvalue; a plane's is 0). It counts only when it explains the normals much better than flat does."""
    if uv.shape[0] < 10:
        return math.inf
    tilt = np.stack([dot3(normals, u_axis), dot3(normals, v_axis)], axis=1)
    tilt -= tilt.mean(axis=0)
    where = uv - uv.mean(axis=0)
    # Least squares tilt = where @ slope, by its 2 x 2 normal equations (einsum: no threaded BLAS, see vec.py).
    gram = np.einsum("ni,nj->ij", where, where)
    if np.linalg.det(gram) <= 1e-12 * max(float(np.trace(gram)), 1e-300) ** 2:  # points on a line: no fit
        return math.inf
    slope = np.linalg.solve(gram, np.einsum("ni,nj->ij", where, tilt))
    flat = float(np.einsum("ij,ij->", tilt, tilt))
    rest = tilt - np.einsum("ni,ij->nj", where, slope)
    curved = float(np.einsum("ij,ij->", rest, rest))
    if flat <= 0.0 or curved > _CURVED_RESIDUAL * flat:
        return math.inf
    kappa = float(np.linalg.eigvalsh(0.5 * (slope + slope.T)).max())
    return 1.0 / kappa if kappa > 1e-9 else math.inf
