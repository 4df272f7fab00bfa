"""Smaller points of the window: recent files (File > Open Recent, kept in QSettings); the description
box wraps; mnemonics in the dialogs; the no-selection message names the eyedropper. (The bag dialog offering
only the pipeline's kind of topics: tests/gui/test_gui_bags.py; a tuned system's description:
tests/gui/test_gui_unsaved.py.)"""

from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QApplication, QDialogButtonBox, QInputDialog, QMessageBox, QPlainTextEdit

from objrec_apps.define import starting_system
from objrec_apps.gui.changes import Answer
from objrec_apps.gui.live_topic_dialog import LiveTopicDialog
from objrec_core import Rect
from tests.qt_waits import HANG_GUARD_MS

from .test_gui_files import patch_dialogs

PARAMS = Path(__file__).resolve().parents[2] / "params"


def recent_labels(gui) -> list[str]:
    gui.recent.rebuild()
    return [action.text() for action in gui.recent.menu.actions() if action.text()]


def test_recent_files_are_offered_in_the_next_run_and_open(make_gui, monkeypatch, tmp_path):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    assert recent_labels(gui) == ["(no recent files)"]
    mine = tmp_path / "mine.yaml"
    patch_dialogs(monkeypatch, save_path=mine)
    assert gui.files.save_as()
    assert gui.files.open(PARAMS / "feature_demo.yaml")
    assert recent_labels(gui) == ["&1 feature_demo.yaml", "&2 mine.yaml", "&Clear the list"]
    gui.close()
    again = make_gui(starting_system("hsv"), paused=True, wait=False)  # the same settings: the next run
    assert recent_labels(again)[:2] == ["&1 feature_demo.yaml", "&2 mine.yaml"]
    file_menu = next(a.menu() for a in again.menuBar().actions() if a.text() == "&File")
    assert again.recent.menu in [a.menu() for a in file_menu.actions()]
    mine_action = next(a for a in again.recent.menu.actions() if a.text() == "&2 mine.yaml")
    mine_action.trigger()
    assert again.files.path == mine.resolve() or again.files.path == mine
    assert recent_labels(again)[0] == "&1 mine.yaml"  # opened again: first
    mine.unlink()
    assert "&1 mine.yaml" not in recent_labels(again)  # gone from disk: not offered


@pytest.mark.timeout(120)
def test_the_description_box_wraps_and_has_a_mnemonic(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    dialog = gui.changes.edit_description()
    qtbot.waitExposed(dialog)
    edit = dialog.findChild(QPlainTextEdit)
    assert edit.lineWrapMode() == QPlainTextEdit.LineWrapMode.WidgetWidth
    long_text = "The red disk of the demo scene, found by its hue on the grey background. " * 4
    edit.setPlainText(long_text)
    block = edit.document().firstBlock()
    qtbot.waitUntil(lambda: block.layout().lineCount() > 2, timeout=HANG_GUARD_MS)  # one paragraph, many lines
    buttons = dialog.findChild(QDialogButtonBox)
    assert [b.text() for b in buttons.buttons()] in (["&OK", "&Cancel"], ["&Cancel", "&OK"])
    dialog.accept()
    assert gui.system.description == long_text.strip() and gui.changes.description_is_users


@pytest.mark.timeout(120)
def test_the_dialogs_have_mnemonics(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False, questions=True)
    seen: list[list[str]] = []

    def look_and_cancel() -> None:
        box = QApplication.activeModalWidget()
        assert isinstance(box, QMessageBox)
        seen.append(sorted(b.text() for b in box.buttons()))
        box.button(QMessageBox.StandardButton.Cancel).click()

    QTimer.singleShot(0, look_and_cancel)
    assert gui.changes.ask_with_dialog("Save them?") is Answer.CANCEL
    assert seen == [["&Cancel", "&Discard", "&Save"]]

    def choose_first() -> None:
        dialog = QApplication.activeModalWidget()
        assert isinstance(dialog, QInputDialog)
        seen.append([dialog.okButtonText(), dialog.cancelButtonText()])
        dialog.accept()

    QTimer.singleShot(0, choose_first)
    assert gui.ask_choice("play which?", ["a", "b"]) == "a"
    assert seen[-1] == ["&OK", "&Cancel"]

    topics = LiveTopicDialog("2d", gui, lister=lambda scheme, options, timeout: [])
    texts = {b.text() for b in topics.buttons.buttons()} | {topics.refresh_button.text(),
                                                            topics.address_label.text()}
    assert {"&Open", "&Cancel", "&Refresh", "&Master"} <= texts
    topics.deleteLater()


@pytest.mark.timeout(120)
def test_the_no_selection_message_names_the_eyedropper(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    gui.hand_selection(Rect(10, 10, 40, 30), None)
    qtbot.waitUntil(lambda: any("did nothing" in m for m in gui.message_area.messages()), timeout=HANG_GUARD_MS)
    message = gui.message_area.messages()[-1]
    assert "eyedropper (Ctrl+E, or hold Shift while dragging)" in message
