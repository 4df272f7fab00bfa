"""The real mug scan survives plane removal asked for more planes than it holds (skipped where ../shared/data is
absent). It holds one, the table: before the plane checks, the second "plane" was the mug's front wall and the
third its next strip (17,609 points left with one plane, 8,356 with two, 3,680 with three; the shipped shape
system then found no mug, or a 2 cm "cylinder" on its handle side)."""

from __future__ import annotations

import logging

import pytest

from objrec3d import DistanceFilter, PlaneRemovalFilter, read_pcd
from objrec_core import build_system

pytestmark = pytest.mark.realdata
log = logging.getLogger(__name__)


@pytest.fixture(scope="module")
def mug(shared_data):
    return read_pcd(shared_data / "clouds" / "table_scene_mug_stereo_textured.pcd")


def test_the_shipped_shape_system_finds_the_mug_with_one_two_or_three_planes_removed(mug, project_root) -> None:
    counts, radii = {}, {}
    for planes in (1, 2, 3):
        system = build_system(project_root / "objrec_apps" / "systems" / "shape_demo.yaml")
        [plane_filter] = [m for m in system.modules if isinstance(m, PlaneRemovalFilter)]
        plane_filter.set_parameters(max_planes=planes)
        result = system.process(mug, keep_stages=True)
        [stage] = [s for s in result.stages or [] if s.id == plane_filter.id]
        counts[planes] = stage.output.count_valid()
        cylinders = [o for o in result.objects if o.shape == "cylinder"]
        assert len(cylinders) == 1, (planes, result.reasons)
        radii[planes] = cylinders[0].radius
        log.info("max_planes %d: %s points after plane removal, cylinder r=%.4f centre %s", planes, counts[planes],
                 radii[planes], cylinders[0].center.round(3))
    assert counts[2] == counts[3] == counts[1] > 15_000  # the table only, however many asked for (17,609 today)
    for planes, radius in radii.items():
        assert abs(radius - 0.0396) <= 0.001, planes  # 0.0394-0.0397 m over seeds; PCL's tutorial 0.0388


def test_a_far_noisy_wall_is_still_a_plane(shared_data) -> None:
    """office1's largest plane is a wall 4-5 m away, where the depth is noisy and so are the normals: it is
    removed still (the unchecked filter removed 42,448 points; a 4,872-point piece of that slab whose normals
    scatter more, 46 % within 20 degrees, now stays)."""
    office = read_pcd(shared_data / "clouds" / "office1.pcd")
    window = DistanceFilter(max_distance=6.0).filter(office)
    removed = window.count_valid() - PlaneRemovalFilter().filter(window).count_valid()
    assert 30_000 <= removed <= 42_448
