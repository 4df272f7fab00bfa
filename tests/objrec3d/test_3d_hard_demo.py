"""The project's own generator made harder (``shape_scene(..., hard=True)``): 1.5 mm x z^2 depth
noise, flying pixels at edges, lying cylinders, boxes as clutter; 0.6-3 m.

Its truth must stay right (the labelled points lie on their shapes within the noise; flying pixels and boxes
belong to no shape), and the detector's recall on it is pinned by visible-point band, organized and not.
Figures (27 scenes, seeds 2400-2428, 2026-11-26), shipped defaults (the segment-then-fit pass on), pooled over
the detector's seeds 0-4 (``SEEDS``): >= 300 visible points organized 259/315 (82 %), unorganized 266/315 (84 %),
no false object. One seed's count moves by two to four objects with the seed or any change of the search's path.
The organized misses are mostly near lying cylinders, which the pass (beyond 1.6 m) does not touch.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from objrec3d import ShapeDetector
from objrec3d.demo import shape_scene
from objrec3d.fitting import fit_plane
from objrec3d.shape_detector import axis_angle_degrees

log = logging.getLogger(__name__)

DISTANCES = np.linspace(0.6, 3.0, 9)
REPEATS = 3
BANDS = ((150, 300), (300, 600), (600, 1500), (1500, 10**9))


def _scenes():
    for repeat in range(REPEATS):
        for index, distance in enumerate(DISTANCES):
            yield float(distance), shape_scene(np.random.default_rng(2400 + 10 * repeat + index), float(distance),
                                               hard=True)


def _without_table(cloud):
    keep = cloud.valid_mask()
    index = np.flatnonzero(keep)
    table = fit_plane(cloud.points[index], 0.015, max_iterations=200, rng=np.random.default_rng(0),
                      origin=cloud.sensor_origin)
    keep[index[table.inliers]] = False
    return cloud.select(keep)


def _within_tolerance(obj, want) -> bool:
    if obj.shape != want.shape or abs(obj.radius - want.radius) > 0.003:
        return False
    rel = obj.center - want.center
    if want.axis is None:
        return float(np.linalg.norm(rel)) <= 0.005
    across = float(np.linalg.norm(rel - (rel @ want.axis) * want.axis))
    return across <= 0.005 and axis_angle_degrees(obj.axis, want.axis) <= 2.0


def _near(obj, want) -> bool:
    reach = want.radius + (want.height / 2 if want.axis is not None else 0.0) + 0.02
    return float(np.linalg.norm(obj.center - want.center)) < reach


def test_hard_scenes_keep_their_truth() -> None:
    lying = boxes_or_flying = 0
    for _, (cloud, truth, labels) in _scenes():
        valid = cloud.valid_mask()
        for index, want in enumerate(truth.shapes):
            mine = cloud.points[valid & (labels == index)].astype(np.float64)
            rel = mine - want.center
            if want.axis is not None:
                lying += abs(float(want.axis @ truth.table_normal)) < 0.1
                along = rel @ want.axis
                side = np.abs(along) < want.height / 2 - 0.003  # the side, not the flat ends
                rel = rel[side] - np.outer(along[side], want.axis)
                mine = mine[side]
            if mine.shape[0] < 30:
                continue
            error = np.abs(np.linalg.norm(rel, axis=1) - want.radius)
            sigma = 0.0015 * mine[:, 2] ** 2
            assert np.median(error / sigma) < 2.0, (want.shape, want.radius)
        boxes_or_flying += int((valid & (labels < 0)).sum() > 0)
    assert lying >= REPEATS * len(DISTANCES)  # a lying cylinder in every scene
    assert boxes_or_flying == REPEATS * len(DISTANCES)


#: The detector's random seeds the recall is pooled over. One seed's count moves by 2-4 objects of 63 with any
#: change of the search's path (which fits it tries, in which order): on the code before a found cylinder's flat
#: ends left the search, seeds 0-4 gave 56, 54, 52, 53 and 55 unorganized, so a pin on one seed was luck either way.
SEEDS = range(5)


@pytest.mark.slow
def test_recall_on_the_hard_scenes_by_visible_points() -> None:
    tally = {path: {"bands": {b: [0, 0] for b in BANDS}, "false": 0} for path in ("organized", "unorganized")}
    scenes = [(_without_table(cloud), truth, labels) for _, (cloud, truth, labels) in _scenes()]
    for seed in SEEDS:
        detector = ShapeDetector(shape="cylinder+sphere", max_objects=6, random_seed=seed)
        for cloud, truth, labels in scenes:
            visible = np.bincount(labels[cloud.valid_mask() & (labels >= 0)], minlength=len(truth.shapes))
            for path, data in (("organized", cloud), ("unorganized", cloud.compacted())):
                found = detector.detect(data)
                for index, want in enumerate(truth.shapes):
                    for band in BANDS:
                        if band[0] <= visible[index] < band[1]:
                            tally[path]["bands"][band][0] += any(_within_tolerance(obj, want) for obj in found)
                            tally[path]["bands"][band][1] += 1
                tally[path]["false"] += sum(not any(_near(obj, want) for want in truth.shapes) for obj in found)
    counts = {}
    for path, result in tally.items():
        log.info("%s, seeds %s: %s; %d false", path, list(SEEDS), ", ".join(
            f"{lo}-{hi}: {f}/{w}" for (lo, hi), (f, w) in result["bands"].items()), result["false"])
        counts[path] = [sum(result["bands"][band][k] for band in BANDS[1:]) for k in (0, 1)]
    (organized, wanted), (unorganized, _) = counts["organized"], counts["unorganized"]
    assert wanted >= 60 * len(SEEDS)
    # Measured (>= 300 points, seeds 0-4): organized 259/315 (82 %), unorganized 266/315 (84 %), none false.
    assert organized >= 0.80 * wanted and unorganized >= 0.84 * wanted, counts
    assert abs(organized - unorganized) <= 0.10 * wanted
    assert tally["organized"]["false"] <= 1 and tally["unorganized"]["false"] == 0
