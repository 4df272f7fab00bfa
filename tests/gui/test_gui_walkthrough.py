"""What a student tripped over in a walk-through at 1280x800 under Xvfb (every shipped system, the mug scan,
a truncated video, the eyedropper on a photo), each kept fixed here:

- a truncated video printed a Python traceback on the terminal when playing or seeking ran into its broken
  frames (a bad file is the user's data: one line in the window, no traceback);
- after such a failure stopped the source, the bar went on showing the last second's frame rate and no
  "(ended)", as if it still played;
- the names of two detections close together in the 3D view were written one over the other;
- the HSV eyedropper's button looked usable on pipelines without an HSV filter (feature, 3D).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest
from PySide6.QtCore import QRectF

from objrec_apps.define import starting_system
from objrec_apps.gui.cloud_view import CloudView
from objrec_apps.gui.eyedropper import NO_FILTER_TOOLTIP, TOOLTIP
from objrec_apps.gui.label_placement import place_labels
from objrec_core import Outline
from tests.gui.test_gui_items_seek import truncated_video
from tests.qt_waits import HANG_GUARD_MS

objrec2d = pytest.importorskip("objrec2d")


@pytest.mark.timeout(120)
def test_a_truncated_video_is_one_line_in_the_window_and_no_traceback(make_gui, qtbot, tmp_path, caplog):
    video, decodable = truncated_video(tmp_path / "cut.avi")
    caplog.set_level(logging.DEBUG)
    gui = make_gui(starting_system("hsv"), source=str(video))
    qtbot.waitUntil(lambda: gui.worker.ended, timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: "cannot be decoded" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    assert [r.getMessage() for r in caplog.records if r.exc_info] == []  # no traceback anywhere
    assert "cannot be decoded" in gui.message_area.messages()[-1]
    # the source stopped at the broken frame: the bars say ended, not the rate of the last second
    bar = gui.source_bar
    qtbot.waitUntil(lambda: "(ended)" in bar.name_label.text(), timeout=HANG_GUARD_MS)
    assert bar.fps_label.text().strip().startswith("ended: 0 frames/s shown")
    assert gui.seek_bar.counter_text == f"frame {decodable} / {decodable}"


def test_labels_close_together_are_stacked_and_kept_inside_the_view():
    sizes = [(80.0, 14.0)] * 3
    anchors = [(100.0, 50.0), (110.0, 52.0), (390.0, 5.0)]  # two nearly on one spot, one past the right edge
    first, second, third = place_labels(anchors, sizes, 400.0, 300.0)
    assert first == QRectF(100, 36, 80, 14)  # the first keeps its place
    assert not first.intersects(second) and second.top() == first.bottom() + 1 and second.left() == 110
    assert third.right() <= 400 and third.top() >= 0  # moved in from the edges, whole
    rects = place_labels([(10.0, 20.0)] * 5, [(50.0, 12.0)] * 5, 400.0, 300.0)
    assert all(not a.intersects(b) for i, a in enumerate(rects) for b in rects[i + 1:])


def test_two_detections_side_by_side_in_the_3d_view_have_readable_names(qtbot):
    from objrec_apps.gui.cloud_render import CloudScene

    view = CloudView()
    qtbot.addWidget(view)
    view.resize(640, 480)
    view.show()
    points = np.random.default_rng(0).uniform(-0.5, 0.5, (2000, 3)) + np.array([0.0, 0.0, 1.5])
    scene = CloudScene.from_layers([("original", points.astype(np.float32))])

    def box(x: float) -> Outline:
        corners = np.array([[x + dx, dy, 1.1 + dz] for dx in (0, 0.08) for dy in (-0.05, 0.05) for dz in (0, 0.08)])
        return Outline(label="cylinder" if x < 0 else "sphere", box=corners.tolist())

    view.set_scene(scene, [box(-0.06), box(0.0)])  # centimetres apart: their top corners nearly meet on screen
    view.camera.fit(scene.bounds(), 640 / 480)
    view.repaint()
    qtbot.waitUntil(lambda: len(view.label_rects) == 2, timeout=HANG_GUARD_MS)
    first, second = view.label_rects
    assert not first.intersects(second)
    assert QRectF(0, 0, view.width(), view.height()).contains(first.united(second))


def test_the_eyedropper_is_greyed_out_without_an_hsv_filter_and_back_with_one(make_gui, qtbot):
    gui = make_gui(starting_system("feature"), paused=True, wait=False)
    action = gui.eyedropper.action
    assert not action.isEnabled() and action.toolTip() == NO_FILTER_TOOLTIP
    gui.system.add_module(objrec2d.HSVFilter("colour"), 0)
    qtbot.waitUntil(action.isEnabled, timeout=HANG_GUARD_MS)
    assert action.toolTip() == TOOLTIP
    action.setChecked(True)
    gui.system.remove_module("colour")
    qtbot.waitUntil(lambda: not action.isEnabled(), timeout=HANG_GUARD_MS)
    assert not action.isChecked()  # drags go to the detectors again
    hsv = make_gui(starting_system("hsv"), paused=True, wait=False)
    assert hsv.eyedropper.action.isEnabled()
