"""Every detector's debug view is on screen: a file with two feature targets shows two match views, each
with its own target beside the frame, in tabs and in the grid."""

from __future__ import annotations

import numpy as np
import pytest

from objrec_apps.define import starting_system
from objrec_core import Rect
from tests.qt_waits import HANG_GUARD_MS

objrec2d = pytest.importorskip("objrec2d")


def two_targets():
    """The shipped poster detector (ORB) and a second one that learnt only the poster's left half (SIFT)."""
    system = starting_system("feature")
    scene = objrec2d.DemoScene()
    frame0, _ = scene.render(0)
    x, y, width, height = scene.target.reference_rect
    half = objrec2d.FeatureDetector("left_half", feature_type="SIFT", min_inliers=8)
    half.process_area_selection(Rect(x, y, width // 2, height), frame0)
    system.add_module(half)
    return system


@pytest.mark.parametrize("mode", ["tabs", "grid"])
def test_two_feature_targets_show_two_debug_views(make_gui, qtbot, tmp_path, mode):
    system = two_targets()
    gui = make_gui(system, view_mode=mode, paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    views = gui.stage_views.views
    assert {"poster:debug", "left_half:debug"} <= set(views)
    frame = gui.last_results.frame.data
    pictures = {key: views[key].image() for key in ("poster:debug", "left_half:debug")}
    for module_id in ("poster", "left_half"):
        picture, target = pictures[f"{module_id}:debug"], gui.system.module(module_id).target.image
        # Side by side: the frame, then this detector's own target (the two targets differ in width).
        assert picture.shape[1] == frame.shape[1] + target.shape[1], module_id
        assert picture.shape[0] == max(frame.shape[0], target.shape[0]), module_id
        stage = next(stage for stage in gui.last_results.stages if stage.id == module_id)
        assert np.array_equal(picture, stage.debug), module_id  # the detector's own view, as it drew it
    assert pictures["poster:debug"].shape[1] > pictures["left_half:debug"].shape[1]
    found = {stage.id: len(stage.objects) for stage in gui.last_results.stages if stage.role == "detector"}
    assert found == {"poster": 1, "left_half": 1}
