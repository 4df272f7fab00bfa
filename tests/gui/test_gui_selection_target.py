"""Two feature detectors in one pipeline get different targets. A selection goes to ONE
detector (the one whose panel was used last, else the user's choice), as one undo step."""

from __future__ import annotations

import pytest
from PySide6.QtCore import QPointF, Qt
from PySide6.QtWidgets import QWidget

from objrec_apps.define import starting_system
from objrec_core import Rect
from tests.gui.test_gui_selection import drag
from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("objrec2d.feature_detector")


def two_detectors():
    import objrec2d

    system = starting_system("feature")
    system.module("poster").clear_target()
    system.add_module(objrec2d.FeatureDetector("second"))
    return system


def _on_frame_0(make_gui, qtbot):
    gui = make_gui(two_detectors(), paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    return gui


def _poster_rect() -> Rect:
    from objrec2d import DemoScene

    x, y, w, h = DemoScene().target.reference_rect
    return Rect(x, y, w, h)


def _select(gui, rect: Rect) -> None:
    view = gui.stage_views.view("input")
    drag(view, view.to_widget(QPointF(rect.x, rect.y)),
         view.to_widget(QPointF(rect.x + rect.width, rect.y + rect.height)))


def _focus_in_panel(gui, qtbot, module_id: str) -> None:
    """Give the keyboard focus to an editor of ``module_id``'s panel, as a click on it would."""
    gui.show()
    qtbot.waitExposed(gui)
    panel = gui.panels.panel(module_id)
    editor = next(w for w in panel.findChildren(QWidget) if w.focusPolicy() & Qt.FocusPolicy.StrongFocus)
    gui.activateWindow()
    editor.setFocus(Qt.FocusReason.MouseFocusReason)
    qtbot.waitUntil(lambda: gui.selection_target.last_panel == module_id, timeout=HANG_GUARD_MS)


@pytest.mark.timeout(120)
def test_the_selection_goes_to_the_detector_whose_panel_was_used_last_in_one_undo_step(make_gui, qtbot):
    gui = _on_frame_0(make_gui, qtbot)
    asked: list[list[str]] = []
    gui.selection_target.ask = lambda title, labels: asked.append(labels) or "poster"
    _focus_in_panel(gui, qtbot, "second")
    steps = gui.undo.stack.count()
    rect = _poster_rect()
    _select(gui, rect)
    second, poster = gui.system.module("second"), gui.system.module("poster")
    qtbot.waitUntil(lambda: second.target is not None, timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: "taken by second" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    assert second.target.rect == rect and poster.target is None  # the other detector keeps its own target
    assert asked == []  # no question: the panel said which
    assert gui.undo.stack.count() == steps + 1  # one step, not one per detector
    gui.undo.stack.undo()
    assert second.target is None and poster.target is None


@pytest.mark.timeout(120)
def test_with_no_panel_used_the_user_chooses_and_cancel_changes_nothing(make_gui, qtbot):
    gui = _on_frame_0(make_gui, qtbot)
    asked: list[list[str]] = []
    answers = iter([None, "poster"])
    gui.selection_target.ask = lambda title, labels: (asked.append(labels), next(answers))[1]
    rect = _poster_rect()
    steps = gui.undo.stack.count()
    _select(gui, rect)  # cancelled
    assert asked == [["poster", "second"]]
    assert "no detector chosen" in gui.statusBar().currentMessage()
    _select(gui, rect)  # poster chosen
    poster, second = gui.system.module("poster"), gui.system.module("second")
    qtbot.waitUntil(lambda: poster.target is not None, timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: "taken by poster" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    assert second.target is None and gui.undo.stack.count() == steps + 1
    assert gui.selection_target.last_panel == "poster"  # the choice is kept for the next selections
