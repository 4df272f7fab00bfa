"""The real scans of ../shared/data/clouds (skipped where absent)."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from objrec3d import DistanceFilter, PlaneRemovalFilter, ShapeDetector, read_pcd
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
