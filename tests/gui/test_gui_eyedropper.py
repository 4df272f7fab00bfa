"""The HSV eyedropper: a rectangle dragged on the demo's red disk sets the HSV filter's ranges, in one
change, to values whose mask covers the disk and none of the other objects; red wraps around hue 0."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from PySide6.QtCore import QEvent, QPointF, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication

from objrec_apps.define import starting_system
from objrec_apps.gui.eyedropper import hsv_filter_of, hsv_ranges
from objrec_core import Change
from tests.qt_waits import HANG_GUARD_MS

objrec2d = pytest.importorskip("objrec2d")

#: Half the side of the square dragged inside the red disk (radius 38 px): well inside its edge.
HALF = 20


def _mouse(widget, kind: QEvent.Type, pos: QPointF, buttons, button, modifiers) -> None:
    event = QMouseEvent(kind, pos, QPointF(widget.mapToGlobal(pos.toPoint())), button, buttons, modifiers)
    QApplication.sendEvent(widget, event)


def drag(widget, start: QPointF, end: QPointF, modifiers=Qt.KeyboardModifier.NoModifier) -> None:
    left, none = Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton
    _mouse(widget, QEvent.Type.MouseButtonPress, start, left, left, modifiers)
    for i in range(1, 5):
        _mouse(widget, QEvent.Type.MouseMove, start + (end - start) * (i / 4), left, none, modifiers)
    _mouse(widget, QEvent.Type.MouseButtonRelease, end, none, left, modifiers)


def object_masks(truth: dict, shape: tuple[int, ...]) -> dict[str, np.ndarray]:
    """Each demo object's pixels, one pixel in from its anti-aliased edge."""
    masks = {}
    for obj in truth["objects"]:
        mask = np.zeros(shape[:2], np.uint8)
        cv2.fillPoly(mask, [np.round(np.asarray(obj["polygon"])).astype(np.int32)], 255)
        masks[obj["name"]] = cv2.erode(mask, np.ones((3, 3), np.uint8)) > 0
    return masks


def check_covers_only_the_red_disk(values: dict[str, int], index: int) -> None:
    frame, truth = objrec2d.DemoScene().render(index)
    mask = objrec2d.HSVFilter("c", **values).filter(frame) > 0
    masks = object_masks(truth, frame.shape)
    assert mask[masks["red"]].mean() >= 0.99  # the disk, whole
    for name in ("green", "blue", "yellow"):
        assert mask[masks[name]].sum() == 0, name  # no other object
    near_objects = cv2.dilate(np.any(list(masks.values()), axis=0).astype(np.uint8), np.ones((7, 7), np.uint8))
    assert mask[near_objects == 0].sum() == 0  # nor the background


def test_ranges_from_red_pixels_wrap_around_hue_zero_and_select_the_disk_only():
    frame, truth = objrec2d.DemoScene().render(0)
    x, y = (int(c) for c in truth["objects"][0]["centroid"])
    values = hsv_ranges(frame[y - HALF:y + HALF, x - HALF:x + HALF])
    assert values["h_min"] > values["h_max"]  # red: a range through 0
    assert 165 <= values["h_min"] <= 179 and 0 <= values["h_max"] <= 10
    assert values["s_min"] >= 120 and values["v_min"] >= 120  # not grey, not dark
    for index in (0, 30, 90):  # the disk moves and the noise changes: the range still holds
        check_covers_only_the_red_disk(values, index)


def test_a_few_stray_pixels_do_not_open_the_range():
    red = np.tile(np.array([40, 35, 215], np.uint8), (400, 1))
    grey = np.tile(np.array([128, 128, 128], np.uint8), (3, 1))  # under 1 %: strays
    values = hsv_ranges(np.concatenate([red, grey]))
    assert values["s_min"] > 150 and values["h_min"] > values["h_max"]
    green = hsv_ranges(np.tile(np.array([45, 190, 40], np.uint8), (50, 1)))
    assert green["h_min"] < green["h_max"] and 50 <= green["h_min"] <= 60 <= green["h_max"] <= 70


def _recorded(gui) -> list[tuple[str, bool]]:
    """What the eyedropper reports, recorded on the way to the window."""
    reports: list[tuple[str, bool]] = []
    report = gui.eyedropper.report
    gui.eyedropper.report = lambda text, error: (reports.append((text, error)), report(text, error))
    return reports


def _window_on_frame_0(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    assert gui.last_results.frame.index == 0
    return gui


@pytest.mark.timeout(60)
@pytest.mark.parametrize("how", ["toolbar", "shift"])
def test_the_eyedropper_on_the_red_disk_sets_the_filter_in_one_change(make_gui, qtbot, how):
    gui = _window_on_frame_0(make_gui, qtbot)
    hsv = hsv_filter_of(gui.system)
    assert hsv is not None and hsv.id == "colour"
    notifications: list[list[Change]] = []
    hsv.watch(lambda changes: notifications.append(list(changes)))
    _, truth = objrec2d.DemoScene().render(0)
    x, y = truth["objects"][0]["centroid"]
    view = gui.stage_views.view("input")
    modifiers = Qt.KeyboardModifier.NoModifier
    if how == "toolbar":
        gui.eyedropper.action.trigger()
        assert gui.eyedropper.action.isChecked()
    else:
        modifiers = Qt.KeyboardModifier.ShiftModifier
    reports = _recorded(gui)
    generation = gui.worker.generation
    drag(view, view.to_widget(QPointF(x - HALF, y - HALF)), view.to_widget(QPointF(x + HALF, y + HALF)), modifiers)
    values = hsv.get_parameters()
    assert len(notifications) == 1  # one set_parameters: one change event, one undo step
    assert {c.name for c in notifications[0]} <= set(values) and len(notifications[0]) >= 4
    assert values["h_min"] > values["h_max"]
    check_covers_only_the_red_disk(values, 0)
    assert reports == [(f"eyedropper: colour set from 40×40 pixels: hue {values['h_min']}..{values['h_max']} "
                        f"(wrapping around 0), saturation {values['s_min']}..{values['s_max']}, "
                        f"value {values['v_min']}..{values['v_max']}", False)]
    # The window reprocesses the frame: the pipeline now finds the disk alone, where it is.
    qtbot.waitUntil(lambda: gui.last_shown_generation > generation, timeout=HANG_GUARD_MS)
    objects = gui.last_results.objects.objects
    assert len(objects) == 1
    points = np.array([[p.x, p.y] for p in objects[0].polygon.points])
    assert np.hypot(*(points.mean(axis=0) - (x, y))) < 3


@pytest.mark.timeout(60)
def test_without_the_eyedropper_a_drag_still_goes_to_the_detectors(make_gui, qtbot):
    gui = _window_on_frame_0(make_gui, qtbot)
    before = hsv_filter_of(gui.system).get_parameters()
    view = gui.stage_views.view("input")
    drag(view, view.to_widget(QPointF(52, 100)), view.to_widget(QPointF(92, 140)))
    assert hsv_filter_of(gui.system).get_parameters() == before


@pytest.mark.timeout(60)
def test_a_pipeline_without_an_hsv_filter_says_so(make_gui, qtbot):
    gui = make_gui(starting_system("feature"), paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    before = gui.system.module("poster").get_parameters()
    gui.eyedropper.action.setChecked(True)
    reports = _recorded(gui)
    view = gui.stage_views.view("input")
    drag(view, view.to_widget(QPointF(52, 100)), view.to_widget(QPointF(92, 140)))
    assert gui.system.module("poster").get_parameters() == before
    assert reports == [("eyedropper: the pipeline has no HSV filter (add one from the Pipeline menu)", True)]
