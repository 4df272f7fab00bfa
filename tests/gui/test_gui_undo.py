"""Undo and redo in the definition window: a slider drag is one step, one set_parameters call is one step,
pipeline edits and target selections are undone and redone, and changes made by undo are not recorded."""

from __future__ import annotations

import pytest
from PySide6.QtCore import QPointF

from objrec_apps.define import starting_system
from tests.qt_waits import HANG_GUARD_MS


def hsv_window(make_gui):
    return make_gui(starting_system("hsv"), paused=True, wait=False)


def test_a_slider_drag_is_one_undo_step(make_gui):
    gui = hsv_window(make_gui)
    colour = gui.system.module("colour")
    editor = gui.panels.panel("colour").editors["h_max"]
    slider = editor.slider
    assert colour.h_max == 179 and gui.undo.stack.count() == 0
    slider.setSliderDown(True)  # pressed: the drag begins
    for position in range(slider.value() - 1, editor.position_of(60) - 1, -1):
        slider.setValue(position)
    slider.setSliderDown(False)  # released: the last position is sent at once
    assert colour.h_max == 60
    assert gui.undo.stack.count() == 1, [gui.undo.stack.text(i) for i in range(gui.undo.stack.count())]
    assert "*" in gui.windowTitle()
    gui.undo_action.trigger()
    assert colour.h_max == 179 and editor.spin.value() == 179
    assert "*" not in gui.windowTitle()  # back where the file was opened: nothing unsaved
    gui.redo_action.trigger()
    assert colour.h_max == 60 and editor.spin.value() == 60
    assert gui.undo.stack.count() == 1  # undo and redo recorded nothing themselves


def test_two_drags_and_typed_values_are_separate_steps(make_gui):
    gui = hsv_window(make_gui)
    colour = gui.system.module("colour")
    editor = gui.panels.panel("colour").editors["s_min"]
    for target in (150, 200):
        editor.slider.setSliderDown(True)
        editor.slider.setValue(editor.position_of(target))
        editor.slider.setSliderDown(False)
    editor.spin.setValue(210)  # typed (or arrow keys): one step per value
    editor.spin.setValue(220)
    assert gui.undo.stack.count() == 4
    seen = []
    for _ in range(4):
        gui.undo_action.trigger()
        seen.append(colour.s_min)
    assert seen == [210, 200, 150, 120]


def test_one_set_parameters_call_is_one_step(make_gui):
    """What the eyedropper does (one call setting six ranges) undoes in one go, without knowing of undo."""
    gui = hsv_window(make_gui)
    colour = gui.system.module("colour")
    before = colour.get_parameters()
    colour.set_parameters(h_min=170, h_max=10, s_min=90, s_max=250, v_min=80, v_max=240)
    assert gui.undo.stack.count() == 1
    gui.undo_action.trigger()
    assert colour.get_parameters() == before
    gui.redo_action.trigger()
    assert (colour.h_min, colour.h_max, colour.s_min, colour.s_max, colour.v_min, colour.v_max) == (
        170, 10, 90, 250, 80, 240)


def test_adding_removing_and_moving_modules_undo_and_redo(make_gui):
    gui = hsv_window(make_gui)
    system = gui.system
    ids = lambda: [m.id for m in system.modules]  # noqa: E731 - a short reader for the asserts
    assert ids() == ["colour", "open", "blobs"]
    added = gui.pipeline_menu.add_module("MorphologyFilter")
    assert added is not None and ids() == ["colour", "open", "MorphologyFilter", "blobs"]
    gui.pipeline_menu.move_module("MorphologyFilter", 0)
    gui.pipeline_menu.remove_module("open")
    assert ids() == ["MorphologyFilter", "colour", "blobs"]
    assert [gui.undo.stack.text(i) for i in range(3)] == ["add MorphologyFilter", "move MorphologyFilter",
                                                         "remove open"]
    gui.undo_action.trigger()
    assert ids() == ["MorphologyFilter", "colour", "open", "blobs"]
    assert [p.module.id for p in gui.panels.panels] == ids()
    gui.undo_action.trigger()
    gui.undo_action.trigger()
    assert ids() == ["colour", "open", "blobs"] and len(gui.panels.panels) == 3
    gui.redo_action.trigger()
    assert ids() == ["colour", "open", "MorphologyFilter", "blobs"]
    assert system.module("MorphologyFilter") is added  # the same module, with its values
    # A module back from undo is observed again: its changes are steps too.
    added.set_parameters(iterations=3)
    assert gui.undo.stack.count() == 2 and gui.undo.stack.text(1) == "MorphologyFilter.iterations = 3"
    gui.undo_action.trigger()
    assert added.iterations == 1


def test_a_target_selection_undoes_and_redoes(make_gui, qtbot):
    pytest.importorskip("objrec2d.feature_detector")
    from objrec2d import DemoScene

    from .test_gui_selection import drag

    system = starting_system("feature")
    detector = system.module("poster")
    shipped = detector.target.rect
    gui = make_gui(system, paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()  # frame 0, where the demo's poster faces the camera
    view = gui.stage_views.view("input")
    x, y, w, h = DemoScene().target.reference_rect
    x, y, w, h = x + 10, y + 10, w - 20, h - 20  # not the shipped target's rectangle
    assert (shipped.x, shipped.y, shipped.width, shipped.height) != (x, y, w, h)
    drag(view, view.to_widget(QPointF(x, y)), view.to_widget(QPointF(x + w, y + h)))
    qtbot.waitUntil(lambda: gui.undo.stack.count() == 1, timeout=HANG_GUARD_MS)  # made in the worker thread
    selected = detector.target.rect
    assert (selected.x, selected.y, selected.width, selected.height) == (x, y, w, h)
    assert gui.undo.stack.text(0) == "poster target"
    gui.undo_action.trigger()
    assert detector.target.rect == shipped
    gui.redo_action.trigger()
    assert detector.target.rect == selected
    assert gui.undo.stack.count() == 1
