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
