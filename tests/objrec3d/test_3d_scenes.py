"""Synthetic scenes at 0.5-2.5 m, organized and not, with and without a 5 mm voxel filter: every object with at
least 150 visible points is found within 5 mm (position), 3 mm (radius) and 2 degrees (axis); one detector
finds cylinders, spheres and the table in one pass."""

from __future__ import annotations

import numpy as np
import pytest

from objrec3d import PlaneRemovalFilter, ShapeDetector, VoxelFilter
from objrec3d.demo import shape_scene
from objrec3d.shape_detector import axis_angle_degrees

DISTANCES = np.linspace(0.5, 2.5, 9)
LEAF = 0.005
MIN_VISIBLE = 150


@pytest.fixture(scope="module")
def scenes():
    """Nine scenes, two cylinders and a sphere each (radii 1.2-8 cm), the table removed."""
    out = []
    for index, distance in enumerate(DISTANCES):
        rng = np.random.default_rng(2000 + index)
        cloud, truth, labels = shape_scene(rng, float(distance))
        out.append((float(distance), PlaneRemovalFilter().filter(cloud), truth, labels))
    return out


def _variants(cloud, labels):
    """(name, detector input, visible points per truth index) for the four ways a cloud reaches a detector."""
    valid = cloud.valid_mask()
    count = labels.max() + 1

    def organized_counts(mask):
        return np.bincount(labels[mask & (labels >= 0)], minlength=count)

    def voxel_counts(points, point_labels):
        counts = np.zeros(count, dtype=int)
        for i in range(count):
            mine = points[point_labels == i]
            counts[i] = len(np.unique(np.floor(mine / LEAF).astype(np.int64), axis=0)) if len(mine) else 0
        return counts

    thinned = VoxelFilter(leaf_size=LEAF).filter(cloud)
    flat = cloud.compacted()
    flat_labels = labels[valid]
    yield "organized", cloud, organized_counts(valid)
    yield "organized + voxel", thinned, organized_counts(thinned.valid_mask())
    yield "unorganized", flat, np.bincount(flat_labels[flat_labels >= 0], minlength=count)
    yield ("unorganized + voxel", VoxelFilter(leaf_size=LEAF, keep_organized=False).filter(flat),
           voxel_counts(flat.points.astype(np.float64), flat_labels))


def _matches(obj, want) -> bool:
    if obj.shape != want.shape or abs(obj.radius - want.radius) > 0.003:
        return False
    rel = obj.center - want.center
    if want.axis is None:
        return float(np.linalg.norm(rel)) <= 0.005
    across = float(np.linalg.norm(rel - (rel @ want.axis) * want.axis))
    return across <= 0.005 and axis_angle_degrees(obj.axis, want.axis) <= 2.0


def test_objects_with_150_visible_points_are_found_at_every_range_and_layout(scenes) -> None:
    detector = ShapeDetector(shape="cylinder+sphere", max_objects=5)
    wanted = good = 0
    report = []
    for distance, cloud, truth, labels in scenes:
        for name, data, visible in _variants(cloud, labels):
            found = detector.detect(data)
            for index, want in enumerate(truth.shapes):
                if visible[index] < MIN_VISIBLE:
                    continue
                wanted += 1
                if any(_matches(obj, want) for obj in found):
                    good += 1
                else:
                    report.append(f"{distance:.2f} m {name}: {want.shape} r={want.radius:.4f} with {visible[index]} "
                                  f"points: got {[(o.shape, round(o.radius, 4)) for o in found]} "
                                  f"({found.reason})")
    assert wanted >= 60  # the set holds enough objects to mean something
    assert good >= 0.95 * wanted, f"{good}/{wanted}\n" + "\n".join(report)


def test_one_detector_finds_two_cylinders_a_sphere_and_the_table() -> None:
    cloud, truth, _ = shape_scene(np.random.default_rng(7), 1.0, radii=(0.03, 0.06))
    found = ShapeDetector(shape="cylinder+sphere+plane", max_objects=6).detect(cloud)
    assert sorted(o.shape for o in found if o.shape != "plane") == ["cylinder", "cylinder", "sphere"]
    for want in truth.shapes:
        assert any(_matches(obj, want) for obj in found), want
    planes = sorted((o for o in found if o.shape == "plane"), key=lambda o: -o.inliers)
    table = planes[0]
    caps = [w.center + w.axis * w.height / 2 for w in truth.of_shape("cylinder")]
    for cap in planes[1:]:  # a cylinder's flat top is a plane too, and nothing else is
        assert min(np.linalg.norm(cap.center - c) for c in caps) < 0.02
    normal = table.box.pose.orientation.as_matrix()[:, 2]
    assert axis_angle_degrees(normal, truth.table_normal) < 1.0
    assert normal @ truth.table_normal > 0  # faces the sensor, as the truth's
    assert table.box.width > 1.0 and table.box.height > 0.5 and table.box.depth < 0.05


def test_same_seed_same_objects_and_reasons_when_nothing_is_found(scenes) -> None:
    _, cloud, _, _ = scenes[2]
    a = ShapeDetector(shape="cylinder+sphere+plane", max_objects=5, random_seed=4).detect(cloud)
    b = ShapeDetector(shape="cylinder+sphere+plane", max_objects=5, random_seed=4).detect(cloud)
    assert a == b and len(a) >= 3
    detector = ShapeDetector(shape="cylinder+sphere", min_radius=0.2, max_radius=0.3)
    result = detector.detect(cloud)
    assert result == [] and result.reason is not None
    assert "cylinder: best fit" in result.reason or "cylinder: no hypothesis" in result.reason
    strict = ShapeDetector(min_inliers=1_000_000).detect(cloud)
    assert strict == [] and "< min_inliers 1000000" in strict.reason
    assert ShapeDetector(shape="cylinder+sphere", max_objects=5).detect(cloud)  # and it finds them otherwise
