"""The small vector helpers the shape search runs on give NumPy's own results to the last bit (they only skip its
overhead), so a search with them finds the very same fits; and the in-place cost matches a plain evaluation."""

from __future__ import annotations

import numpy as np

from objrec3d.fitting import _costs, _workspace
from objrec3d.vec import cross3, norms, pair_dots, row_dots, squared_norms


def test_helpers_match_numpy_bit_for_bit() -> None:
    rng = np.random.default_rng(11)
    for trial in range(120):
        n = int(rng.integers(1, 5000))
        dtype = np.float32 if trial % 2 else np.float64
        for k in (2, 3):
            x = (rng.normal(size=(n, k)) * 3).astype(dtype)
            y = rng.normal(size=(n, k)).astype(dtype)
            assert np.array_equal(norms(x), np.linalg.norm(x, axis=1))
            assert np.array_equal(squared_norms(x), (x * x).sum(axis=1))
            assert np.array_equal(row_dots(x, y), (x * y).sum(axis=1))
        a = rng.normal(size=(n, 3)).astype(dtype)
        b = rng.normal(size=(n, 3))
        v = rng.normal(size=3)
        assert np.array_equal(cross3(a, b), np.cross(a, b))
        assert np.array_equal(cross3(a, v), np.cross(a, v))
        assert np.array_equal(cross3(v, [1.0, 0.0, 0.0]), np.cross(v, [1.0, 0.0, 0.0]))
        h = int(rng.integers(1, 300))
        c = rng.normal(size=(h, 3)).astype(dtype)
        expected = c[:, 0, None] * a[None, :, 0]
        expected += c[:, 1, None] * a[None, :, 1]
        expected += c[:, 2, None] * a[None, :, 2]
        assert np.array_equal(pair_dots(c, a), expected)


def _plain_costs(shape: str, centers: np.ndarray, axes: np.ndarray, radii: np.ndarray, pts: np.ndarray,
                 nrm: np.ndarray, weight: float) -> np.ndarray:
    """The cost's formula with plain NumPy temporaries (``_costs`` before it computed in a workspace)."""
    cp = centers @ pts.T
    v2 = (pts * pts).sum(axis=1)[None, :] - 2.0 * cp + (centers * centers).sum(axis=1)[:, None]
    nv = (nrm * pts).sum(axis=1)[None, :] - centers @ nrm.T
    if shape == "sphere":
        dist2, nr = v2, nv
    else:
        along = axes @ pts.T - (centers * axes).sum(axis=1)[:, None]
        dist2, nr = v2 - along * along, nv - along * (axes @ nrm.T)
    dist = np.sqrt(np.maximum(dist2, 1e-12))
    angle = np.arccos(np.clip(nr / dist, -1.0, 1.0))
    return weight * angle + (1.0 - weight) * np.abs(dist - radii[:, None])


def test_batch_costs_in_a_reused_workspace_match_the_formula() -> None:
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(700, 3)) * 0.1
    nrm = rng.normal(size=(700, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    work = _workspace(64, 700, np.float64)
    for shape in ("cylinder", "sphere"):
        for h in (64, 17, 1):  # later batches reuse the first rows of the same arrays
            centers = rng.normal(size=(h, 3)) * 0.05
            axes = rng.normal(size=(h, 3))
            axes /= np.linalg.norm(axes, axis=1, keepdims=True)
            radii = rng.uniform(0.01, 0.1, h)
            got = _costs(shape, centers, axes, radii, pts, nrm, squared_norms(pts), row_dots(nrm, pts), 0.05,
                         None, work)
            want = _plain_costs(shape, centers, axes, radii, pts, nrm, 0.05)
            assert got.shape == (h, 700)
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
