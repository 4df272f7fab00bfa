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


def _standing_cylinder_with_top(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, int]:
    """A 4 cm cylinder's visible side (points, outward normals), then its top disc (normals along the axis),
    then a 2 cm sphere's cap beside the top: the points, the normals and where the top starts."""
    angle = rng.uniform(-1.3, 1.3, 2000)
    height = rng.uniform(-0.06, 0.06, 2000)
    side_n = np.stack([np.sin(angle), np.zeros_like(angle), -np.cos(angle)], axis=1)
    side = 0.04 * side_n + np.stack([np.zeros_like(height), height, np.zeros_like(height)], axis=1)
    r = 0.04 * np.sqrt(rng.uniform(0.0, 1.0, 800))
    phi = rng.uniform(0.0, 2.0 * np.pi, 800)
    top = np.stack([r * np.cos(phi), np.full_like(r, -0.06), r * np.sin(phi)], axis=1)
    top_n = np.tile([0.0, -1.0, 0.0], (800, 1))
    direction = rng.normal(size=(300, 3))
    direction[:, 2] = -np.abs(direction[:, 2])  # the side facing the sensor
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    sphere = np.array([0.065, -0.07, 0.0]) + 0.02 * direction
    points = np.concatenate([side, top, sphere]) + np.array([0.0, 0.0, 1.0])
    return points, np.concatenate([side_n, top_n, direction]), side.shape[0]


def test_a_found_cylinders_flat_ends_are_its_top_and_nothing_beside_it() -> None:
    from objrec3d.fitting import ShapeFit
    from objrec3d.shape_detector import cap_points

    points, normals, top_starts = _standing_cylinder_with_top(np.random.default_rng(1))
    fit = ShapeFit("cylinder", np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]), 0.04,
                   np.arange(top_starts), 0.0)
    ends = cap_points(fit, points, normals, np.arange(points.shape[0]), 0.01)
    assert not ends[:top_starts].any()  # the side is the cylinder's, not its ends
    assert ends[top_starts:top_starts + 800].all()  # the whole top, up to the radius
    assert not ends[top_starts + 800:].any()  # the sphere touching the top's rim is left to the search
    sphere = ShapeFit("sphere", np.zeros(3), None, 0.04, np.arange(top_starts), 0.0)
    assert not cap_points(sphere, points, normals, np.arange(points.shape[0]), 0.01).any()


def test_no_search_nibbles_a_found_cylinders_top(monkeypatch) -> None:
    """After a standing cylinder seen from above is found, its top is not searched again: before, most rounds
    after the scene's last object fitted a sliver of it (6-10 cm radius over 20-50 degrees, refused), a round each."""
    from objrec3d import PlaneRemovalFilter, ShapeDetector
    from objrec3d import shape_detector as module
    from objrec3d.demo import shape_scene

    searched: list[tuple[np.ndarray, np.ndarray, object]] = []  # the points and normals searched, the result
    search = module.ShapeDetector._search

    def recording(self, shape, points, normals, alive, *rest, **kw):
        result = search(self, shape, points, normals, alive, *rest, **kw)
        searched.append((points, normals, result[0]))
        return result

    monkeypatch.setattr(module.ShapeDetector, "_search", recording)
    nibbles = rounds = 0
    for seed, distance in ((9002, 1.0), (9003, 1.25), (9013, 1.5), (9022, 1.5)):  # the benchmark's scenes
        cloud, _, _ = shape_scene(np.random.default_rng(seed), distance)
        searched.clear()
        detector = ShapeDetector(shape="cylinder+sphere", max_objects=6, segment_noise=0.0)
        detector.detect(PlaneRemovalFilter().filter(cloud))
        points, normals, _ = searched[0]
        cylinders = [r.fit for _, _, r in searched if isinstance(r, module.Found) and r.fit.shape == "cylinder"]
        assert cylinders, seed
        for _, _, result in searched:
            if isinstance(result, np.ndarray):  # a refused fit's inliers
                rounds += 1
                nibbles += any(module.cap_points(c, points, normals, result, 0.01).mean() > 0.5 for c in cylinders)
    assert rounds >= 8  # the scenes still end with refused fits: only the tops are not among them
    assert nibbles == 0


def test_percentile_95_is_numpys_to_the_bit() -> None:
    """A sphere's coverage takes the 95th percentile by one partition: the same value as np.percentile."""
    from objrec3d.shape_detector import percentile_95

    rng = np.random.default_rng(11)
    for n in [*range(1, 60), 137, 900, 1999]:
        values = np.abs(rng.normal(size=n))
        assert percentile_95(values) == np.percentile(values, 95), n
    assert percentile_95(np.full(40, 0.25)) == 0.25


def test_longest_circular_run_wraps_around() -> None:
    from objrec3d.shape_detector import longest_circular_run

    flags = np.zeros(36, dtype=bool)
    assert longest_circular_run(flags) == 0
    flags[[0, 1, 2, 33, 34, 35]] = True  # one run of six across the seam
    flags[10:15] = True
    assert longest_circular_run(flags) == 6
    flags[20:32] = True
    assert longest_circular_run(flags) == 12
    rng = np.random.default_rng(4)
    for _ in range(500):  # against the plain reading of the flags twice
        flags = rng.random(36) < rng.random()
        if flags.all():
            continue
        run = best = 0
        for flag in np.concatenate([flags, flags]):
            run = run + 1 if flag else 0
            best = max(best, run)
        assert longest_circular_run(flags) == best


def test_a_cylinders_coverage_is_its_arc() -> None:
    """Inliers over 120 degrees of a cylinder cover the 12 or 13 10-degree bins they touch, a cap of a sphere its
    angular diameter."""
    from objrec3d.fitting import ShapeFit
    from objrec3d.shape_detector import coverage

    rng = np.random.default_rng(2)
    angle = rng.uniform(np.radians(5.0), np.radians(125.0), 2000)
    points = np.stack([0.04 * np.cos(angle), rng.uniform(-0.05, 0.05, angle.size), 0.04 * np.sin(angle)], axis=1)
    cylinder = ShapeFit("cylinder", np.zeros(3), np.array([0.0, 1.0, 0.0]), 0.04, np.arange(angle.size), 0.0)
    assert coverage(cylinder, points) in (120.0, 130.0)
    direction = rng.normal(size=(3000, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    cap = direction[direction[:, 2] > np.cos(np.radians(30.0))]  # a cap 60 degrees across
    sphere = ShapeFit("sphere", np.zeros(3), None, 1.0, np.arange(cap.shape[0]), 0.0)
    assert 48.0 < coverage(sphere, cap) <= 60.0  # the 95th percentile: a little under the whole 60


def test_the_largest_connected_piece_is_found() -> None:
    """Two groups of points apart by more than a cell: the larger; a chain of touching cells is one piece."""
    from objrec3d.shape_detector import largest_cluster

    rng = np.random.default_rng(6)
    small = rng.uniform(0.0, 0.02, (300, 3))
    large = rng.uniform(0.0, 0.02, (500, 3)) + np.array([0.1, 0.0, -0.05])
    points = np.concatenate([small, large])
    np.testing.assert_array_equal(largest_cluster(points, 0.01), np.arange(300, 800))
    chain = np.stack([np.linspace(0.0, 0.3, 400), np.zeros(400), np.zeros(400)], axis=1)
    assert largest_cluster(np.concatenate([chain, small + np.array([0.0, 0.5, 0.0])]), 0.01).size == 400


def test_the_arcs_bin_medians_are_lexsorts() -> None:
    """The visible arc's per-bin medians by a value sort and a stable 8-bit bin sort: lexsort's values."""
    from objrec3d.arc_checks import _bin_medians, by_bin_and_value

    rng = np.random.default_rng(9)
    for n in (5, 40, 1500):
        bins = rng.integers(0, 37, n).astype(np.uint8)
        values = np.round(rng.normal(size=n), 2)  # ties within a bin included
        np.testing.assert_array_equal(values[by_bin_and_value(bins, values)], values[np.lexsort((values, bins))])
        counts = np.bincount(bins)
        sizes = counts[counts > 0]
        starts = np.cumsum(sizes) - sizes
        ordered = values[np.lexsort((values, bins))]
        np.testing.assert_array_equal(_bin_medians(bins, values, starts, sizes), ordered[starts + (sizes - 1) // 2])
