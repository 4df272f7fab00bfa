"""The label mode: a box dragged and a polygon clicked on the demo's frames become labels of those frames,
undo and redo go through the window's undo stack, the labels survive stepping to another frame, and a save
reopened gives the same labels (COCO JSON through the 2D kind); unsaved labels are asked about on quit."""

from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtCore import QEvent, QPointF, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication

from objrec_apps.define import starting_system
from objrec_apps.gui.changes import Answer
from objrec_apps.gui.label_model import Label
from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("objrec2d.truth", reason="the 2D truth (objrec2d/truth.py) is not there yet")

LEFT, NONE = Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton


def _mouse(widget, kind: QEvent.Type, pos: QPointF, buttons, button) -> None:
    event = QMouseEvent(kind, pos, QPointF(widget.mapToGlobal(pos.toPoint())), button, buttons,
                        Qt.KeyboardModifier.NoModifier)
    QApplication.sendEvent(widget, event)


def drag(view, start: QPointF, end: QPointF) -> None:
    """A left drag between two image points."""
    a, b = view.to_widget(start), view.to_widget(end)
    _mouse(view, QEvent.Type.MouseButtonPress, a, LEFT, LEFT)
    for i in range(1, 5):
        _mouse(view, QEvent.Type.MouseMove, a + (b - a) * (i / 4), LEFT, NONE)
    _mouse(view, QEvent.Type.MouseButtonRelease, b, NONE, LEFT)


def click_polygon(view, corners: list[tuple[float, float]]) -> None:
    """Click each corner; the last click is a double-click (press, release, double-click, release)."""
    for x, y in corners:
        at = view.to_widget(QPointF(x, y))
        _mouse(view, QEvent.Type.MouseButtonPress, at, LEFT, LEFT)
        _mouse(view, QEvent.Type.MouseButtonRelease, at, NONE, LEFT)
    at = view.to_widget(QPointF(*corners[-1]))
    _mouse(view, QEvent.Type.MouseButtonDblClick, at, LEFT, LEFT)
    _mouse(view, QEvent.Type.MouseButtonRelease, at, NONE, LEFT)


@pytest.fixture
def labelling(make_gui, qtbot):
    """``labelling()``: a window on the demo's frame 0 in label mode; its labels are not asked about when the
    test ends (this fixture ends before make_gui's, which closes the window)."""
    windows = []

    def make():
        windows.append(labelling_window(make_gui, qtbot))
        return windows[-1]

    yield make
    for gui in windows:
        gui.labels.store.mark_saved(None)


def labelling_window(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    gui.labels.set_active(True)
    assert gui.labels.frame is not None and gui.labels.frame.index == 0
    assert gui.stage_views.view("input").tool is gui.labels.tool
    return gui


def near(a: tuple[float, ...], b: tuple[float, ...], tolerance: float = 1.0) -> bool:
    return len(a) == len(b) and all(abs(x - y) <= tolerance for x, y in zip(a, b, strict=True))


@pytest.mark.timeout(120)
def test_draw_undo_step_save_and_reopen(labelling, qtbot, tmp_path: Path):
    gui = labelling()
    view = gui.stage_views.view("input")
    mode = gui.labels
    drag(view, QPointF(40, 80), QPointF(110, 160))
    assert len(mode.labels()) == 1
    box = mode.labels()[0]
    assert box.name == gui.system.object_name and not box.polygon
    assert box.box is not None and near(box.box, (40, 80, 70, 80))
    mode.set_shape("polygon")
    mode.name_box.setCurrentText("yellow")
    corners = [(530.0, 320.0), (610.0, 320.0), (570.0, 400.0)]
    click_polygon(view, corners)
    assert [label.name for label in mode.labels()] == [gui.system.object_name, "yellow"]
    polygon = mode.labels()[1].polygon
    assert len(polygon) == 3 and all(near(p, c) for p, c in zip(polygon, corners, strict=True))
    assert mode.store.keyed_by == "index" and mode.store.modified
    assert not gui.changes.modified  # label edits are not unsaved parameters

    gui.undo_action.trigger()
    assert [label.name for label in mode.labels()] == [gui.system.object_name]
    gui.redo_action.trigger()
    assert [label.name for label in mode.labels()] == [gui.system.object_name, "yellow"]
    gui.undo_action.trigger()
    gui.undo_action.trigger()
    assert mode.labels() == () and len(mode.store) == 0  # the first label undone: frame 0 not labelled at all
    gui.redo_action.trigger()
    gui.redo_action.trigger()
    assert len(mode.labels()) == 2

    # Ctrl+click selects the box, Delete removes it (an undo step too).
    at = view.to_widget(QPointF(60, 100))
    event = QMouseEvent(QEvent.Type.MouseButtonPress, at, QPointF(view.mapToGlobal(at.toPoint())), LEFT, LEFT,
                        Qt.KeyboardModifier.ControlModifier)
    QApplication.sendEvent(view, event)
    assert mode.tool.selected == 0
    mode.delete_selected()
    assert [label.name for label in mode.labels()] == ["yellow"]
    gui.undo_action.trigger()
    assert len(mode.labels()) == 2

    # Step to frame 1: no labels there; draw one; frame 0 keeps its two.
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    assert mode.frame.index == 1 and mode.labels() == ()
    mode.set_shape("box")
    mode.name_box.setCurrentText("red")
    drag(view, QPointF(30, 60), QPointF(120, 170))
    assert mode.store.keys == [0, 1]
    kept = {key: mode.store.labels(key) for key in mode.store.keys}

    path = tmp_path / "labels.json"
    assert mode.save(str(path))
    assert path.is_file() and not mode.store.modified
    mode.store.load_truth(mode.store.to_truth("2d"))  # forget what is in memory ...
    mode.store.set_labels(0, ())  # ... and change it, so the reopen must bring the file's labels back
    mode.store.mark_saved(None)
    assert mode.open(str(path))
    assert mode.store.keys == [0, 1] and mode.store.keyed_by == "index"
    for key, labels in kept.items():
        reopened = mode.store.labels(key)
        assert [label.name for label in reopened] == [label.name for label in labels]
        for old, new in zip(labels, reopened, strict=True):
            if old.polygon:
                assert all(near(a, b, 0.01) for a, b in zip(old.polygon, new.polygon, strict=True))
            else:
                assert new.box is not None and old.box is not None and near(new.box, old.box, 0.01)


@pytest.mark.timeout(120)
def test_unsaved_labels_are_asked_about_on_quit(labelling, tmp_path: Path):
    gui = labelling()
    drag(gui.stage_views.view("input"), QPointF(40, 80), QPointF(110, 160))
    questions: list[str] = []
    gui.changes.ask = lambda question: (questions.append(question), Answer.CANCEL)[1]
    gui.close()
    assert gui.isVisible() and questions == ["The labels have unsaved changes. Save them before quitting?"]
    path = tmp_path / "quit.json"
    gui.labels.store.path = str(path)
    gui.changes.ask = lambda question: (questions.append(question), Answer.SAVE)[1]
    gui.close()
    assert not gui.isVisible() and path.is_file()
    reopened = gui.labels.store
    assert reopened.labels(0)[0].name == gui.system.object_name


def test_a_label_knows_its_inside():
    triangle = Label("t", None, ((0.0, 0.0), (10.0, 0.0), (0.0, 10.0)))
    assert triangle.contains(2, 2) and not triangle.contains(8, 8)
    assert triangle.bounds == (0.0, 0.0, 10.0, 10.0)
    assert Label("b", (5, 5, 10, 4)).contains(15, 9) and not Label("b", (5, 5, 10, 4)).contains(16, 9)


def test_frames_with_stamps_are_keyed_by_stamp_and_survive_a_save(tmp_path: Path):
    """A bag's frames carry header stamps: the labels are keyed by them (a recording cut differently keeps
    them), written as such and read back so."""
    import numpy as np

    from objrec_apps.gui.label_model import LabelStore
    from objrec_core import Frame, get_kind

    kind = get_kind("2d")
    store = LabelStore()
    picture = np.zeros((48, 64, 3), np.uint8)
    first = Frame(picture, index=0, stamp_ns=1_700_000_000_000_000_000)
    second = Frame(picture, index=1, stamp_ns=1_700_000_000_050_000_000)
    store.set_labels(store.key_of(first), [Label("mug", (4.0, 5.0, 20.0, 10.0))], first)
    store.set_labels(store.key_of(second), [Label("mug", None, ((1.0, 1.0), (9.0, 1.0), (5.0, 8.0)))], second)
    assert store.keyed_by == "stamp" and store.keys == [first.stamp_ns, second.stamp_ns]
    path = tmp_path / "bag-labels.json"
    kind.write_truth(path, store.to_truth(kind.name))
    truth = kind.read_truth(path)
    assert truth.keyed_by == "stamp" and [f.stamp_ns for f in truth] == [first.stamp_ns, second.stamp_ns]
    reopened = LabelStore()
    reopened.load_truth(truth)
    assert reopened.keyed_by == "stamp" and not reopened.modified
    assert reopened.labels(first.stamp_ns) == (Label("mug", (4.0, 5.0, 20.0, 10.0)),)
    assert reopened.labels(second.stamp_ns)[0].polygon == ((1.0, 1.0), (9.0, 1.0), (5.0, 8.0))


@pytest.mark.timeout(120)
def test_opening_labels_keeps_the_parameter_history_and_ignores_older_label_steps(labelling, tmp_path: Path):
    gui = labelling()
    mode = gui.labels
    view = gui.stage_views.view("input")
    drag(view, QPointF(40, 80), QPointF(110, 160))
    path = tmp_path / "one.json"
    assert mode.save(str(path))
    gui.system.module("colour").set_parameters(s_min=130)  # an unsaved parameter change
    drag(view, QPointF(500, 300), QPointF(600, 400))  # a second label, unsaved
    gui.labels.store.mark_saved(gui.labels.store.path)  # (discarded: nothing to ask on opening)
    assert mode.open(str(path))
    assert len(mode.labels()) == 1 and gui.changes.modified
    gui.undo_action.trigger()  # the label step made before the file was opened: does nothing
    assert len(mode.labels()) == 1
    gui.undo_action.trigger()  # the parameter change: undone
    assert gui.system.module("colour").get_parameters()["s_min"] == 120
