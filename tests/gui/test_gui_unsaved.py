"""Never lose work: quitting or opening another file with unsaved changes asks (Save, Discard, Cancel) in a
real dialog; the title marks unsaved changes; both Restore choices; the saved description follows the
values unless it is the user's own text."""

from __future__ import annotations

import yaml
from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QApplication, QMessageBox

from objrec_apps.define import starting_system
from objrec_apps.gui.changes import describe

from .test_gui_files import patch_dialogs


def answer_with(button: QMessageBox.StandardButton, asked: list[str]) -> None:
    """Press ``button`` in the unsaved-changes dialog once it is open (its own event loop runs the timer)."""

    def press() -> None:
        box = QApplication.activeModalWidget()
        assert isinstance(box, QMessageBox) and box.objectName() == "unsaved_changes"
        asked.append(box.text())
        box.button(button).click()

    QTimer.singleShot(0, press)


def hsv_window(make_gui):
    return make_gui(starting_system("hsv"), paused=True, wait=False, questions=True)


def test_quit_with_unsaved_changes_asks_and_cancel_keeps_the_window(make_gui):
    gui = hsv_window(make_gui)
    assert gui.close() is True and not gui.isVisible()  # nothing changed: closes without asking
    gui = hsv_window(make_gui)
    gui.system.module("colour").set_parameters(h_min=20)
    asked: list[str] = []
    answer_with(QMessageBox.StandardButton.Cancel, asked)
    assert gui.close() is False
    assert asked and "unsaved changes" in asked[0] and "quitting" in asked[0]
    assert gui.isVisible() and gui.system.module("colour").h_min == 20 and "*" in gui.windowTitle()
    answer_with(QMessageBox.StandardButton.Discard, asked)
    assert gui.close() is True and not gui.isVisible() and len(asked) == 2


def test_save_on_quit_writes_the_file_and_the_title_marks_changes(make_gui, monkeypatch, tmp_path):
    gui = hsv_window(make_gui)
    assert "*" not in gui.windowTitle()
    gui.system.module("colour").set_parameters(s_min=200)
    assert "*" in gui.windowTitle()
    target = tmp_path / "mine.yaml"
    patch_dialogs(monkeypatch, save_path=target)
    asked: list[str] = []
    answer_with(QMessageBox.StandardButton.Save, asked)
    assert gui.close() is True and asked
    saved = yaml.safe_load(target.read_text())
    assert saved["pipeline"][0]["parameters"]["s_min"] == 200


def test_saving_clears_the_mark_and_open_asks_first(make_gui, monkeypatch, tmp_path):
    gui = hsv_window(make_gui)
    first = tmp_path / "first.yaml"
    patch_dialogs(monkeypatch, save_path=first)
    gui.system.module("colour").set_parameters(v_min=90)
    gui.save_as_action.trigger()
    assert gui.windowTitle().startswith("objrec-define — first.yaml (")  # saved: no mark
    gui.system.module("colour").set_parameters(v_min=100)
    assert "first.yaml*" in gui.windowTitle()
    calls = patch_dialogs(monkeypatch, open_path=first)
    asked: list[str] = []
    answer_with(QMessageBox.StandardButton.Cancel, asked)
    gui.open_action.trigger()
    assert asked and "opening another file" in asked[0]
    assert calls["open"] == [] and gui.system.module("colour").v_min == 100  # nothing opened
    answer_with(QMessageBox.StandardButton.Discard, asked)
    gui.open_action.trigger()
    assert len(calls["open"]) == 1 and gui.system.module("colour").v_min == 90
    assert "*" not in gui.windowTitle() and gui.undo.stack.count() == 0  # a new document


def test_restore_the_opened_values_or_the_declared_defaults(make_gui):
    gui = hsv_window(make_gui)
    colour = gui.system.module("colour")
    shipped = colour.get_parameters()
    assert shipped["s_min"] == 120 and shipped != colour.default_values()
    colour.set_parameters(h_min=30, s_min=10)
    panel = gui.panels.panel("colour")
    panel.restore_button.click()
    assert colour.get_parameters() == colour.default_values()
    assert colour.s_min == 0 and colour.v_min == 0  # the declared defaults pass everything
    panel.restore_opened_button.click()
    assert colour.get_parameters() == shipped
    assert gui.undo.stack.count() == 3  # each restore is one step
    gui.undo_action.trigger()
    assert colour.get_parameters() == colour.default_values()


def test_the_description_follows_the_values_unless_it_is_the_users(make_gui, monkeypatch, tmp_path):
    system = starting_system("hsv")
    system.description = ""  # a system nobody described
    gui = make_gui(system, paused=True, wait=False, questions=True)
    morphology = gui.system.module("open")
    morphology.set_parameters(operation="dilate")
    target = tmp_path / "generated.yaml"
    patch_dialogs(monkeypatch, save_path=target)
    gui.save_as_action.trigger()
    text = yaml.safe_load(target.read_text())["description"]
    assert "operation dilate" in text and "operation open" not in text and text == describe(gui.system)
    # Reopened, the generated text is still recognised as generated: it follows the next change.
    gui.files.load(target)
    morphology.set_parameters(operation="close")
    gui.save_action.trigger()
    assert "operation close" in yaml.safe_load(target.read_text())["description"]
    # The user's own text is saved as it is, whatever the values do.
    gui.changes.set_description("The red disk, for the demo.")
    morphology.set_parameters(operation="erode")
    gui.save_action.trigger()
    assert yaml.safe_load(target.read_text())["description"] == "The red disk, for the demo."


def test_a_shipped_description_is_the_authors_own_text_until_the_system_is_tuned(make_gui, monkeypatch, tmp_path):
    """A system started from a shipped file (objrec-define hsv) and tuned is no longer what
    the shipped description says; saved untuned, the author's text stays."""
    gui = hsv_window(make_gui)
    gui.files.set_origin("hsv_demo.yaml")  # what objrec-define does for a shipped system
    written = gui.system.description
    assert written.startswith("Saturated objects") and gui.changes.description_is_users
    untuned = tmp_path / "kept.yaml"
    patch_dialogs(monkeypatch, save_path=untuned)
    gui.save_as_action.trigger()
    assert yaml.safe_load(untuned.read_text())["description"] == written
    gui.files.set_origin("hsv_demo.yaml")
    gui.system.module("colour").set_parameters(h_min=5)
    tuned = tmp_path / "tuned.yaml"
    patch_dialogs(monkeypatch, save_path=tuned)
    gui.save_as_action.trigger()
    text = yaml.safe_load(tuned.read_text())["description"]
    assert text == describe(gui.system) and "h_min 5" in text
    # a file of the user's own keeps the text, tuned or not
    gui.files.load(untuned)
    gui.system.module("colour").set_parameters(h_min=9)
    gui.save_action.trigger()
    assert yaml.safe_load(untuned.read_text())["description"] == written
