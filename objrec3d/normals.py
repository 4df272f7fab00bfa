"""Surface normals, as fast as the input allows.

An organized cloud gets its normals from the image grid: points are box-averaged with integral images
(PCL's AVERAGE_3D_GRADIENT idea) and the normal is the cross product of the horizontal and vertical
gradients of those means, a few additions per point. An unorganized cloud needs a neighbour search: the
smallest eigenvector of the covariance of nearby points (SciPy's k-d tree). How near is chosen from the data
(``neighbourhood_radius``): a fixed k spans a few millimetres in a dense cloud close to the sensor, where the
depth noise is as large as that, and the normals are noise.

Normals are unit float32 vectors oriented toward the sensor (``n . (origin - p) >= 0``); a point whose
normal cannot be estimated (too few neighbours, a depth jump, neighbours all on one line or at one spot)
gets NaN.

Degenerate clouds stay cheap: a k-d tree cannot split points that coincide, so a query among thousands of
copies of one point visits every copy; searches are therefore made among the distinct points whenever
copies show up.
"""

from __future__ import annotations

import numpy as np

from .cloud import PointCloud
from .voxel_filter import cell_groups


def estimate_normals(cloud: PointCloud, indices: np.ndarray, *, window: int = 3, knn: int = 30,
                     radius: float = 0.0) -> np.ndarray:
    """Normals at ``cloud.points[indices]`` (valid points only): the image grid when the cloud is organized,
    a neighbourhood chosen from the data among the given points otherwise (``adaptive_normals``)."""
    if cloud.is_organized:
        return grid_normals(cloud, indices, window=window)
    return adaptive_normals(cloud.points[indices], knn, cloud.sensor_origin, radius)


def grid_normals(cloud: PointCloud, indices: np.ndarray, *, window: int = 3, max_slant: float = 0.12) -> np.ndarray:
    """Normals of an organized cloud at the flat ``indices`` from its grid.

    ``window`` is the half-size in pixels of the averaging box and the gradient step. A gradient longer
    than ``max_slant`` x depth marks a depth discontinuity (or a surface seen nearly edge-on): NaN.
    """
    indices = np.asarray(indices, dtype=np.int64)
    out = np.full((indices.size, 3), np.nan, dtype=np.float32)
    if indices.size == 0:
        return out
    h, w = cloud.height, cloud.width
    r = int(window)
    rows, cols = np.divmod(indices, w)
    # Integral image over the bounding box that matters only (a detector's input is often a small part of the
    # frame), in float64: cumulative sums of metres over a whole image lose millimetres in float32.
    top, bottom = max(int(rows.min()) - 2 * r - 1, 0), min(int(rows.max()) + 2 * r + 2, h)
    left, right = max(int(cols.min()) - 2 * r - 1, 0), min(int(cols.max()) + 2 * r + 2, w)
    grid = cloud.points.reshape(h, w, 3)[top:bottom, left:right]
    hh, ww = bottom - top, right - left
    values = np.zeros((hh + 1, ww + 1, 4), dtype=np.float64)
    inner = values[1:, 1:]
    valid = np.isfinite(grid[..., 0] + grid[..., 1] + grid[..., 2])
    np.copyto(inner[..., :3], grid, where=valid[..., None])
    inner[..., 3] = valid
    np.cumsum(values, axis=0, out=values)
    np.cumsum(values, axis=1, out=values)
    rows = rows - top
    cols = cols - left
    # Box sums of every pixel of the bounding box at once (slices of the integral image), then the box means.
    # Edge padding of the integral image is the clamping of the box at the border; then each box sum is
    # four slices, no gathers.
    pad = np.pad(values, ((r, r), (r, r), (0, 0)), mode="edge")
    k = 2 * r + 1
    box = pad[k : k + hh, k : k + ww] - pad[:hh, k : k + ww] - pad[k : k + hh, :ww] + pad[:hh, :ww]
    count = box[..., 3]
    need = (r + 1) ** 2  # at least a quarter of a box must be valid
    # The box means, NaN where too few are valid; neighbours outside the box read as missing (NaN) too,
    # which invalidates the normal below.
    padded = np.full((hh + 2 * r, ww + 2 * r, 3), np.nan, dtype=np.float32)
    count = np.where(count >= need, count, np.nan)
    padded[r : r + hh, r : r + ww] = box[..., :3] / count[..., None]
    pr, pc = rows + r, cols + r
    du = (padded[pr, pc + r] - padded[pr, pc - r]).astype(np.float64)
    dv = (padded[pr + r, pc] - padded[pr - r, pc]).astype(np.float64)
    normals = np.cross(du, dv)
    length = np.sqrt(np.einsum("ij,ij->i", normals, normals))
    points = cloud.points[indices]
    depth = points[:, 2].astype(np.float64)
    limit = max_slant * np.abs(depth)
    du_length, dv_length = np.sqrt(np.einsum("ij,ij->i", du, du)), np.sqrt(np.einsum("ij,ij->i", dv, dv))
    # Gradients (nearly) parallel, or apart by float32 rounding only, span no surface: a line, or one spot.
    with np.errstate(invalid="ignore"):
        across = np.maximum(_MIN_SINE * du_length * dv_length,
                            _RESOLUTION * np.abs(depth) * np.maximum(du_length, dv_length))
        ok = (length > across) & (du_length < limit) & (dv_length < limit)
    normals = normals[ok] / length[ok, None]
    _orient(normals, points[ok], cloud.sensor_origin)
    out[ok] = normals
    return out


def knn_normals(points: np.ndarray, k: int = 30, origin: np.ndarray | None = None, *,
                at: np.ndarray | None = None) -> np.ndarray:
    """Normals from the ``k`` nearest of ``points`` (PCA), oriented to ``origin``: at the points themselves, or
    at ``at`` (other points on the same surface)."""
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=np.float64)
    targets = points if at is None else np.asarray(at, dtype=np.float64)
    out = np.full((targets.shape[0], 3), np.nan, dtype=np.float32)
    k = min(int(k), points.shape[0])
    if points.shape[0] < 3 or k < 3:
        return out
    tree = cKDTree(points)
    for start in range(0, targets.shape[0], 20_000):  # bounded memory: n x k x 3 per chunk
        chunk = targets[start : start + 20_000]
        _, neighbours = tree.query(chunk, k=k, workers=-1)
        local = points[neighbours]  # n x k x 3
        local -= local.mean(axis=1, keepdims=True)
        values, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
        normals = vectors[:, :, 0]
        # Neighbours spread along one direction only (a line, one spot; the rest float32 rounding) leave the
        # normal undetermined.
        rounding = k * (_RESOLUTION * np.abs(chunk).max(axis=1)) ** 2
        normals[~(values[:, 1] > np.maximum(_MIN_SINE**2 * values[:, 2], rounding))] = np.nan
        _orient(normals, chunk, np.zeros(3) if origin is None else origin)
        out[start : start + chunk.shape[0]] = normals
    return out


def no_surface(points: np.ndarray) -> str:
    """Why ``points`` (finite, N x 3) span no surface, for a user whose cloud has no normals: "all one
    point" or "on one line" (float32 rounding aside), or "" when they do span one. A few milliseconds."""
    points = np.asarray(points, dtype=np.float64)
    if points.shape[0] == 0:
        return ""
    centre = points.mean(axis=0)
    centred = points - centre
    values = np.linalg.eigvalsh(np.einsum("ni,nj->ij", centred, centred) / points.shape[0])
    rounding = (_RESOLUTION * float(np.abs(centre).max() + np.sqrt(max(values[2], 0.0)))) ** 2
    if not values[2] > rounding:
        return "the points are all one point"
    if not values[1] > max(_MIN_SINE**2 * values[2], rounding):
        return "the points lie on one line"
    return ""


def distinct_points(points: np.ndarray) -> np.ndarray:
    """``points`` without repeated copies of a point (in some order)."""
    rows = np.ascontiguousarray(np.asarray(points, dtype=np.float64) + 0.0)  # + 0.0: -0.0 is 0.0
    unique = np.unique(rows.view(np.dtype((np.void, rows.dtype.itemsize * 3))).reshape(-1))
    return unique.view(np.float64).reshape(-1, 3)


def neighbourhood_radius(points: np.ndarray, k: int = 30, sample: int = 2000,
                         rng: np.random.Generator | None = None) -> float:
    """A normal's neighbourhood radius from the data: wide enough to hold about ``k`` points at the cloud's
    median spacing (nearest-neighbour distance), and at least eight times the median noise across the
    surface (the square root of the smallest covariance eigenvalue of ``k`` neighbours), so that noise tilts a
    normal by a few degrees at most. Measured on ``sample`` points, so it costs a few milliseconds."""
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=np.float64)
    n = points.shape[0]
    if n < 4:
        return 0.0
    rng = rng if rng is not None else np.random.default_rng(0)
    probe = points[rng.choice(n, size=sample, replace=False)] if n > sample else points
    if distinct_points(probe).shape[0] < probe.shape[0]:  # copies of points: measure among distinct ones
        points = distinct_points(points)
        n = points.shape[0]
        if n < 4:
            return 0.0
        probe = points[rng.choice(n, size=sample, replace=False)] if n > sample else points
    k = max(3, min(int(k), n))
    distances, neighbours = cKDTree(points).query(probe, k=k)
    spacing = float(np.median(distances[:, 1]))
    local = points[neighbours]
    local -= local.mean(axis=1, keepdims=True)
    values = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", local, local) / k)
    noise = float(np.median(np.sqrt(np.maximum(values[:, 0], 0.0))))
    return max(spacing * np.sqrt(k / np.pi), 8.0 * noise)


def adaptive_normals(points: np.ndarray, k: int = 30, origin: np.ndarray | None = None, radius: float | None = None
                     ) -> np.ndarray:
    """Normals of unorganized points over a neighbourhood of ``radius`` (None: ``neighbourhood_radius``).

    The points are first averaged in cubic cells of side radius / sqrt(k / pi), so about ``k`` cell means lie
    within ``radius`` of any point however dense the cloud; each normal is the PCA of the ``k`` cell means
    nearest to its point (a sparse cloud, where cells hold one point, gets plain k nearest neighbours).
    """
    points = np.asarray(points, dtype=np.float64)
    if points.shape[0] < 3 or no_surface(points):  # one spot or a line: no neighbourhood search needed to see it
        return np.full((points.shape[0], 3), np.nan, dtype=np.float32)
    radius = radius if radius else neighbourhood_radius(points, k)
    cell = radius / np.sqrt(max(k, 3) / np.pi)
    if cell <= 0:  # fewer than four distinct points
        return knn_normals(distinct_points(points), k, origin, at=points)
    group, _ = cell_groups(np.floor((points - points.min(axis=0)) / cell))
    sizes = np.bincount(group).astype(np.float64)
    means = np.stack([np.bincount(group, points[:, i]) for i in range(3)], axis=1) / sizes[:, None]
    return knn_normals(means, k, origin, at=points)


#: Two directions closer than this sine (0.06 degrees) to parallel span no plane: no normal from them.
_MIN_SINE = 1e-3
#: A spread below this fraction of the coordinates' size is float32 rounding (a few units in the last place),
#: not a surface: a micrometre at a metre, where a depth sensor's noise is a millimetre.
_RESOLUTION = 1e-6


def _orient(normals: np.ndarray, points: np.ndarray, origin: np.ndarray) -> None:
    """Flip normals in place to face the sensor."""
    flip = np.einsum("ij,ij->i", normals, np.asarray(origin) - points) < 0
    normals *= np.where(flip, -1.0, 1.0).astype(normals.dtype)[:, None]
