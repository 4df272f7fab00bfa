"""The real scans of ../shared/data/clouds (skipped where absent)."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from objrec3d import DistanceFilter, PlaneRemovalFilter, ShapeDetector, read_pcd
from objrec3d.cloud import PointCloud
from objrec3d.fitting import fit_plane
from objrec3d.shape_detector import axis_angle_degrees
from objrec_core import RecognitionSystem

pytestmark = pytest.mark.realdata
log = logging.getLogger(__name__)


@pytest.fixture(scope="module")
def clouds(shared_data):
    folder = shared_data / "clouds"
    return {name: read_pcd(folder / f"{name}.pcd")
            for name in ("table_scene_mug_stereo_textured", "office1", "milk_cartoon_all_small_clorox")}


def test_the_scans_load_organized_with_their_finite_points(clouds) -> None:
    mug = clouds["table_scene_mug_stereo_textured"]
    assert (mug.width, mug.height, mug.count_valid()) == (640, 480, 209_280)
    assert mug.colors is not None


def test_the_mug_is_a_cylinder_of_pcls_radius_along_the_table_normal_for_every_seed(clouds) -> None:
    cloud = clouds["table_scene_mug_stereo_textured"]
    near = DistanceFilter(max_distance=1.5).filter(cloud)
    table = fit_plane(near.points[near.valid_mask()], 0.015, rng=np.random.default_rng(0))
    prepared = PlaneRemovalFilter().filter(near)
    radii = []
    for seed in range(20):
        objects = ShapeDetector(random_seed=seed).detect(prepared)
        assert len(objects) == 1, seed
        mug = objects[0]
        angle = axis_angle_degrees(mug.axis, table.normal)
        log.info("seed %d: r=%.4f axis %.2f deg from the table normal, centre %s, height %.3f, %d inliers", seed,
                 mug.radius, angle, mug.center.round(4), mug.box.height, mug.inliers)
        assert abs(mug.radius - 0.0388) <= 0.001, seed
        assert angle <= 1.0, seed
        assert mug.axis @ table.normal > 0  # both face the sensor
        assert np.linalg.norm(mug.center - [0.055, 0.065, 0.764]) < 0.01  # PCL's centre, to within its inliers
        radii.append(mug.radius)
    system = RecognitionSystem([DistanceFilter(max_distance=1.5), PlaneRemovalFilter(), ShapeDetector()])
    assert system.process(cloud).objects[0].radius == radii[0]  # the same through a system


OFFICE_WINDOW = 6.0  # office1's points lie 1.8-5.4 m away: this window holds every one of them


@pytest.mark.parametrize("shape", ["cylinder", "sphere", "cylinder+sphere"])
def test_office1_holds_no_cylinder_and_no_sphere_at_defaults(clouds, shape: str) -> None:
    cloud = clouds["office1"]
    window = DistanceFilter(max_distance=OFFICE_WINDOW).filter(cloud)
    assert window.count_valid() == cloud.count_valid() > 250_000  # the window is not empty: it is everything
    detector = ShapeDetector(shape=shape, max_objects=3)
    system = RecognitionSystem([DistanceFilter(max_distance=OFFICE_WINDOW), PlaneRemovalFilter(), detector])
    result = system.process(cloud)
    assert result.objects == []
    assert result.reasons[detector.id]  # and it says why


def test_milk_carton_scene_runs(clouds) -> None:
    """Reported in docs/3d.md, whatever it is."""
    cloud = clouds["milk_cartoon_all_small_clorox"]
    system = RecognitionSystem([DistanceFilter(max_distance=1.5), PlaneRemovalFilter(), ShapeDetector(),
                                ShapeDetector("sphere", shape="sphere")])
    objects = system.process(cloud).objects
    for obj in objects:
        log.info("milk scene: %s r=%.4f centre %s height %.3f inliers %d", obj.shape, obj.radius,
                 obj.center.round(3), obj.box.height, obj.inliers)
    assert all(0.01 <= o.radius <= 0.1 for o in objects)


def table_removed_plainly(cloud: PointCloud) -> PointCloud:
    """The table taken out as a plain dominant-plane filter would (the largest plane within 1.5 cm, none of
    PlaneRemovalFilter's checks): the detergent bottle's flat sides reach the detector whole, as they did when
    they made a false cylinder."""
    near = DistanceFilter(max_distance=1.5).filter(cloud)
    keep = near.valid_mask()
    index = np.flatnonzero(keep)
    table = fit_plane(near.points[index], 0.015, max_iterations=200, rng=np.random.default_rng(0),
                      origin=near.sensor_origin)
    keep[index[table.inliers]] = False
    return near.select(keep)


CLOROX_CENTRE = np.array([0.184, -0.089, 0.745])  # PCL's scan: the bottle's box centre as the detector reports it


ARC_CHECKS_OFF = {"min_turn": 0.0, "min_arc_normals": 0.0, "max_sag": 100.0, "max_wave": 90.0}


@pytest.mark.parametrize("shipped_filter", [False, True])
def test_milk_scan_gives_the_clorox_bottle_and_nothing_else_at_three_objects(clouds, shipped_filter: bool) -> None:
    """Flat-sided objects are not cylinders: the detergent bottle (rounded corners, flat faces) gave a 9.8 cm
    cylinder next to the Clorox bottle for every seed, and with the visible arc's checks off seed 2 gives a 5.0 cm
    one on the other flat-sided object's rounded edge (seed 1 gave it, 5.1 cm, before a found cylinder's flat ends
    left the search with it). The visible arc around each fit gives them away (``arc_checks``): the normals there
    turn 0.66 degrees per degree of arc on the 5.0 cm edge (0.96 on the Clorox bottle), agree with the fit on 69 %
    and 73 % of the two edges' arcs (98-99 % on the bottle), and the 5.0 cm edge's distances sag by 5 times their
    noise. Over ten seeds: the Clorox bottle and nothing else."""
    cloud = clouds["milk_cartoon_all_small_clorox"]
    if shipped_filter:
        prepared = PlaneRemovalFilter().filter(DistanceFilter(max_distance=1.5).filter(cloud))
    else:
        prepared = table_removed_plainly(cloud)
    for seed in range(10):
        objects = ShapeDetector(max_objects=3, random_seed=seed).detect(prepared)
        assert len(objects) == 1, (seed, [o.radius for o in objects])
        (clorox,) = objects
        assert np.linalg.norm(clorox.center[[0, 2]] - CLOROX_CENTRE[[0, 2]]) < 0.01, seed
        assert 0.058 <= clorox.radius <= 0.065, seed
    # Either check alone rejects the detergent bottle: the inside share, and the arc's profile.
    assert len(ShapeDetector(max_objects=3, max_inside=1.0).detect(prepared)) == 1
    assert len(ShapeDetector(max_objects=3, **ARC_CHECKS_OFF).detect(prepared)) == 1
    strict = ShapeDetector(max_objects=3, max_inside=1.0, **ARC_CHECKS_OFF).detect(prepared)
    assert len(strict) == 2 and max(o.radius for o in strict) > 0.09
    # and the arc's profile is what rejects seed 2's rounded edge
    edge = ShapeDetector(max_objects=3, random_seed=2, **ARC_CHECKS_OFF).detect(prepared)
    assert sorted(round(o.radius, 3) for o in edge) == [0.05, 0.062]


def test_the_inside_check_passes_the_mug_and_the_clorox_bottle(clouds) -> None:
    from objrec3d.shape_detector import inside_share

    for name, want in (("table_scene_mug_stereo_textured", 0.0388), ("milk_cartoon_all_small_clorox", 0.0614)):
        prepared = table_removed_plainly(clouds[name])
        detector = ShapeDetector()
        points, normals, _ = detector.points_with_normals(prepared)
        (found,) = detector.find(prepared)
        assert abs(found.fit.radius - want) < 0.002
        assert inside_share(found.fit, points, normals, 0.01) < 0.05, name
