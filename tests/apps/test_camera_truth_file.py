"""The simulated camera's truth as a 3D label file: written through the kind, read back, and scoring the lab's
shipped cylinder settings on the camera's frames with the point-cloud kind's scorer."""

from __future__ import annotations

import math

import pytest

from navigation.camera import RGBDCamera
from navigation.geometry import Pose2D
from navigation.maps import load_map
from navigation.world import load_world
from objrec_apps.camera_truth import CameraTruth
from objrec_core import Frame, build_system, get_kind
from objrec_core.evaluation import score
from tests.apps.test_eval_inspection import LAB, MAP, WORLD

CYLINDER = (1.5, 5.3)


def facing(x: float, y: float) -> Pose2D:
    return Pose2D(x, y, math.atan2(CYLINDER[1] - y, CYLINDER[0] - x))


def test_the_camera_s_truth_file_reads_back_and_scores_the_lab_s_cylinder_settings(tmp_path):
    occ_map, world = load_map(MAP), load_world(WORLD)
    camera = RGBDCamera(random_seed=1)
    # From the mission's pose (found there), from the south-east at 2 m, and facing away (nothing in view).
    poses = [facing(2.8, 4.5), facing(1.5 + 2.0 * math.cos(-0.5), 5.3 + 2.0 * math.sin(-0.5)),
             Pose2D(2.8, 4.5, math.pi / 2)]
    frames = [camera.render(world, occ_map, pose, t=2.5 * i) for i, pose in enumerate(poses)]
    recorder = CameraTruth()
    for frame in frames:
        recorder.add(frame)
    path = tmp_path / "views.truth.yaml"
    recorder.write(path)
    kind = get_kind("3d")
    truth = kind.read_truth(path)
    assert truth.kind == "3d" and truth.indices == [0, 1, 2] and truth.names == ["green_cylinder"]
    assert [f.stamp_ns for f in truth.frames] == [0, 2_500_000_000, 5_000_000_000]
    [first], [second], third = (f.objects for f in truth.frames)
    assert third == ()  # labelled: nothing in view
    assert first.shape == "cylinder" and (first.radius, first.height) == (0.12, 0.6)
    assert first.centre == pytest.approx((0.0, 0.0, math.dist((2.8, 4.5), CYLINDER)), abs=1e-12)
    assert second.centre[2] == pytest.approx(2.0, abs=1e-12) and first.visible_points > second.visible_points > 5000

    system = build_system(LAB / "params" / "cylinder_3d.yaml")
    labelled = [(Frame(kind.from_rgbd(f.color, f.depth, f.fx, f.fy, f.cx, f.cy), index=i), truth.lookup(i))
                for i, f in enumerate(frames)]
    rows = {r["name"]: r for r in score(system, kind, labelled).summary_rows()}
    cylinder = rows["green_cylinder"]
    assert (cylinder["truth"], cylinder["tp"], cylinder["fp"], cylinder["fn"]) == (2, 2, 0, 0)
    # The fitted cylinders lie where the camera's truth says, in the same optical frame: about 1 cm off (a fit
    # to the visible front half of a noisy surface), the radius within 2 mm.
    assert cylinder["centre_error_p90"] < 0.02 and cylinder["radius_error_p90"] < 0.002
