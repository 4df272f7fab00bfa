"""The connected pieces of a fit's inliers in NumPy (for speed): the same pieces as SciPy's sparse graph,
without its conversions on every fit judged."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from objrec3d.shape_detector import cell_components


def test_cell_components_are_scipys_pieces() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        count = int(rng.integers(1, 300))
        edges = int(rng.integers(0, 3 * count))
        rows, cols = rng.integers(0, count, edges), rng.integers(0, count, edges)
        mine = cell_components(count, rows, cols)
        _, theirs = connected_components(coo_matrix((np.ones(edges), (rows, cols)), shape=(count, count)),
                                         directed=False)
        # The same partition: every (mine, theirs) label pair is one piece of each.
        pairs = set(zip(mine.tolist(), theirs.tolist(), strict=True))
        assert len(pairs) == len(set(mine.tolist())) == len(set(theirs.tolist()))
        assert np.all(mine <= np.arange(count))  # the smallest node of each piece


def test_a_long_chain_settles() -> None:
    count = 4000
    order = np.random.default_rng(0).permutation(count)
    label = cell_components(count, order[:-1], order[1:])
    assert np.all(label == 0)


def test_a_batch_is_scored_on_the_whole_subsample_for_its_best_few_only(monkeypatch) -> None:
    """Preemptive scoring: every hypothesis on about PREEMPT_POINTS points, the PREEMPT_KEEP best on all 1,024."""
    from objrec3d import fitting
    from objrec3d.fitting import PREEMPT_KEEP, PREEMPT_POINTS, ShapeSettings, ransac_shape

    rng = np.random.default_rng(5)
    angle = rng.uniform(-1.2, 1.2, 6000)
    height = rng.uniform(-0.05, 0.05, 6000)
    radius = 0.03
    normals = np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=1)
    points = normals * radius + np.stack([np.zeros_like(height), np.zeros_like(height), height], axis=1)
    points += rng.normal(0.0, 0.0005, points.shape) + np.array([0.0, 0.0, 1.0])
    scored: list[tuple[int, int]] = []
    costs = fitting._costs

    def counting(shape, centers, *rest, **kw):
        scored.append((centers.shape[0], rest[2].shape[0]))  # hypotheses, points
        return costs(shape, centers, *rest, **kw)

    monkeypatch.setattr(fitting, "_costs", counting)
    settings = ShapeSettings(shape="cylinder", min_radius=0.01, max_radius=0.1, threshold=0.01, normal_weight=0.05)
    fit = ransac_shape(points, normals, settings, np.random.default_rng(0))
    assert fit is not None and abs(fit.radius - radius) < 0.001
    batches = [(h, m) for h, m in scored if h > 1]
    assert batches
    whole = [h for h, m in batches if m == 1024]
    preemptive = [m for h, m in batches if m != 1024]
    assert whole and max(whole) <= PREEMPT_KEEP  # only the best few on every point of the subsample
    assert preemptive and all(PREEMPT_POINTS <= m < 2 * PREEMPT_POINTS for m in preemptive)

