"""File>Save and File>Open through the window with the dialogs patched: every value and the feature target
come back, a broken file changes nothing and says why in the status bar, the last folder and the layout
are remembered."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from PySide6.QtWidgets import QFileDialog

from objrec_apps.define import starting_system
from objrec_apps.gui.changes import Answer
from objrec_apps.gui.param_widgets import BoolEditor, ChoiceEditor, NumberEditor, OptionalEditor, TextEditor
from objrec_core import ParameterStorage


def patch_dialogs(monkeypatch, open_path: Path | None = None, save_path: Path | None = None) -> dict[str, list]:
    calls: dict[str, list] = {"open": [], "save": []}

    def get_open(parent, caption, folder, filters):
        calls["open"].append(folder)
        if open_path is None:
            raise AssertionError("the open dialog was not expected")
        return str(open_path), filters

    def get_save(parent, caption, start, filters):
        calls["save"].append(start)
        if save_path is None:
            raise AssertionError("the save dialog was not expected")
        return str(save_path), filters

    monkeypatch.setattr(QFileDialog, "getOpenFileName", staticmethod(get_open))
    monkeypatch.setattr(QFileDialog, "getSaveFileName", staticmethod(get_save))
    return calls


def discard_when_asked(gui) -> list[str]:
    """Answer Discard to the unsaved-changes question; returns the questions asked."""
    asked: list[str] = []
    gui.changes.ask = lambda question: (asked.append(question), Answer.DISCARD)[1]
    return asked


def change_every_value_through_the_panels(gui) -> None:
    """Give every parameter of every module a valid non-default value, as a user would: via its widget."""
    for panel in gui.panels.panels:
        # Backwards, so each maximum moves before its minimum: min_contour_length may not pass its maximum.
        for name, editor in reversed(panel.editors.items()):
            before = panel.module.get_parameters()[name]
            if isinstance(editor, OptionalEditor):  # none <-> a value, as a user ticks the box
                editor.none.setChecked(not editor.none.isChecked())
            elif isinstance(editor, NumberEditor):
                if editor.slider is not None:
                    position = max(1, editor.slider.maximum() // 3)
                    if editor.value_at(position) == before:  # a third of the way may be the value already
                        position += 1
                    editor.slider.setValue(position)
                    editor.throttle.flush()
                else:
                    editor.spin.setValue(editor.spin.value() + editor.spin.singleStep())
            elif isinstance(editor, BoolEditor):
                editor.check.setChecked(not editor.check.isChecked())
            elif isinstance(editor, ChoiceEditor):
                combo = editor.combo
                combo.setCurrentIndex((combo.currentIndex() + 1) % combo.count())
            elif isinstance(editor, TextEditor):
                editor.line.setText(editor.line.text() + "x")
                editor.line.editingFinished.emit()
            assert panel.module.get_parameters()[name] != before, f"{panel.module.id}.{name} did not change"


def values(system) -> dict[str, dict]:
    return {m.id: m.get_parameters() for m in system.modules}


@pytest.mark.parametrize("system", ["hsv", "feature", "shape"])
def test_save_then_open_restores_every_value(make_gui, monkeypatch, tmp_path, system):
    gui = make_gui(starting_system(system))
    modules = gui.system.modules
    change_every_value_through_the_panels(gui)
    expected = values(gui.system)
    path = tmp_path / "tuned"
    calls = patch_dialogs(monkeypatch, save_path=path)
    gui.save_as_action.trigger()
    saved = tmp_path / "tuned.yaml"  # Save As adds the suffix
    assert saved.is_file() and calls["save"]
    assert gui.statusBar().currentMessage() == f"Saved {saved}"
    assert gui.path_label.toolTip() == str(saved) and "tuned.yaml" in gui.windowTitle()
    assert gui.path_label.text().endswith("tuned.yaml")  # long paths are elided in the middle
    document = yaml.safe_load(saved.read_text())
    assert {e["id"]: e["parameters"] for e in document["pipeline"]} == expected

    for module in modules:
        module.reset_parameters()
    assert values(gui.system) != expected
    patch_dialogs(monkeypatch, open_path=saved)
    asked = discard_when_asked(gui)  # the resets are unsaved changes: opening asks first
    gui.open_action.trigger()
    assert len(asked) == 1 and "opening another file" in asked[0]
    assert values(gui.system) == expected
    assert gui.system.modules == modules  # the same pipeline: modules (and panels) kept
    shown = 0
    for panel in gui.panels.panels:  # every number widget shows the reopened value
        for name, editor in panel.editors.items():
            if isinstance(editor, NumberEditor):
                assert editor.spin.value() == pytest.approx(expected[panel.module.id][name]), (panel.module.id, name)
                shown += 1
    assert shown >= 3
    if system == "hsv":
        assert gui.panels.panel("colour").editors["h_min"].slider.value() == expected["colour"]["h_min"]
    assert gui.statusBar().currentMessage().startswith(f"Opened {saved}")


def test_save_overwrites_the_current_file_without_asking(make_gui, monkeypatch, tmp_path):
    gui = make_gui(starting_system("hsv"))
    path = tmp_path / "colour.yaml"
    patch_dialogs(monkeypatch, save_path=path)
    gui.save_action.trigger()  # no file yet: Save asks once
    patch_dialogs(monkeypatch)  # from now on any dialog fails the test
    gui.system.module("colour").set_parameters(h_min=33)
    gui.save_action.trigger()
    assert yaml.safe_load(path.read_text())["pipeline"][0]["parameters"]["h_min"] == 33
    other = tmp_path / "copy.yaml"
    calls = patch_dialogs(monkeypatch, save_path=other)
    gui.save_as_action.trigger()  # a file is set, yet Save As always asks
    assert len(calls["save"]) == 1 and other.is_file()
    assert gui.statusBar().currentMessage() == f"Saved {other}"
    assert gui.save_action.shortcut().toString() == "Ctrl+S"
    assert gui.save_as_action.shortcut().toString() == "Ctrl+Shift+S"
    assert gui.open_action.shortcut().toString() == "Ctrl+O"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("format_version: 1\nkind: 2d\npipeline:\n- type: HSVFilter\n  id: colour\n  parameters: {h_min: 300}\n",
         "pipeline[0].parameters.h_min"),
        ("format_version: 1\nkind: 2d\npipeline: [\n", "not valid YAML"),
        ("format_version: 1\nkind: 2d\npipeline:\n- type: NoSuchFilter\n", "pipeline[0].type"),
    ],
)
def test_opening_a_broken_file_changes_nothing_and_says_why(make_gui, monkeypatch, tmp_path, text, expected):
    gui = make_gui(starting_system("hsv"))
    gui.system.module("colour").set_parameters(h_min=12)
    modules, before = gui.system.modules, values(gui.system)
    title = gui.windowTitle()
    broken = tmp_path / "broken.yaml"
    broken.write_text(text)
    patch_dialogs(monkeypatch, open_path=broken)
    asked = discard_when_asked(gui)
    gui.open_action.trigger()
    assert len(asked) == 1  # discarding only lets the open go on: a failed open still changes nothing
    assert gui.system.modules == modules and values(gui.system) == before
    message = gui.statusBar().currentMessage()
    assert message.startswith(f"Not opened: {broken}") and expected in message
    assert "Traceback" not in message
    assert gui.windowTitle() == title and gui.files.path is None


def test_opening_another_pipeline_replaces_it_and_its_panels(make_gui, monkeypatch, tmp_path):
    gui = make_gui(starting_system("hsv"))
    other = starting_system("hsv")
    other.remove_module("open")
    other.module("colour").set_parameters(h_min=100, h_max=130)
    path = tmp_path / "two.yaml"
    ParameterStorage(other).save_parameters(path)
    patch_dialogs(monkeypatch, open_path=path)
    gui.open_action.trigger()
    assert [m.id for m in gui.system.modules] == ["colour", "blobs"]
    assert [p.module.id for p in gui.panels.panels] == ["colour", "blobs"]
    assert gui.panels.panel("colour").editors["h_max"].slider.value() == 130


def test_the_feature_target_survives_save_and_open(make_gui, monkeypatch, tmp_path):
    pytest.importorskip("objrec2d.feature_detector")
    from objrec2d import DemoScene
    from objrec_core import Rect

    gui = make_gui(starting_system("feature"), paused=True, wait=False)
    detector = gui.system.module("poster")
    scene = DemoScene()
    frame0, _ = scene.render(0)
    detector.process_area_selection(Rect(*scene.target.reference_rect), frame0)
    detector.set_parameters(ratio=0.7, min_inliers=12, orb_fast_threshold=15)
    target, expected = detector.target, detector.get_parameters()
    path = tmp_path / "feature.yaml"
    patch_dialogs(monkeypatch, save_path=path)
    gui.save_as_action.trigger()
    assert "target" in yaml.safe_load(path.read_text())["pipeline"][0]["state"]

    detector.clear_target()
    detector.reset_parameters()
    patch_dialogs(monkeypatch, open_path=path)
    discard_when_asked(gui)
    gui.open_action.trigger()
    restored = gui.system.module("poster")
    assert restored.get_parameters() == expected
    assert restored.target is not None and restored.target.rect == target.rect
    assert np.array_equal(restored.target.image, target.image)
    assert len(restored.target) == len(target)
    panel = gui.panels.panel("poster")
    assert not panel.thumbnail.pixmap().isNull()


def test_last_folder_and_layout_are_remembered(make_gui, monkeypatch, tmp_path, settings):
    folder = tmp_path / "parameter files"
    folder.mkdir()
    gui = make_gui(starting_system("hsv"))
    patch_dialogs(monkeypatch, save_path=folder / "a.yaml")
    gui.save_as_action.trigger()
    gui.set_view_mode("grid")
    gui.resize(760, 560)  # within the offscreen screen (800 x 800): restoreGeometry keeps windows on it
    size = (gui.width(), gui.height())
    assert size != (1200, 800)
    gui.close()

    again = make_gui(starting_system("hsv"), size=None)
    assert again.stage_views.mode == "grid" and again.mode_actions["grid"].isChecked()
    assert (again.width(), again.height()) == size
    calls = patch_dialogs(monkeypatch, open_path=folder / "a.yaml")
    again.open_action.trigger()
    assert calls["open"] == [str(folder)]
