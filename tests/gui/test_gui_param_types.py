"""Editors come from a registry keyed by parameter class (magicgui style): a plug-in's parameter type
(tests/param_plugin's ``Colour``) gets its own editor in generated panels with no framework edit; optional
parameters get a "none" check box; open bounds keep the widgets inside the interval."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from PySide6.QtCore import Qt

from objrec_apps.gui import ParameterPanel
from objrec_apps.gui.param_widgets import (
    NumberEditor,
    OptionalEditor,
    ParameterEditor,
    ReadOnlyEditor,
    TextEditor,
    editor_for,
    register_editor,
    unregister_editor,
)
from objrec_core import Filter, Float, Int, Str

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "param_plugin"))
from objrec_colour import Colour, TintFilter
from objrec_colour import editor as colour_editor


@pytest.fixture
def colour_editors():
    """The plug-in's editor registered for the test, forgotten after it."""
    colour_editor.register()
    yield colour_editor.ColourEditor
    colour_editor.unregister()


def type_into(qtbot, line, text: str) -> None:
    line.selectAll()
    qtbot.keyClicks(line, text)
    qtbot.keyClick(line, Qt.Key.Key_Return)


def test_a_panel_shows_the_plugin_editor_and_edits_the_value(qtbot, colour_editors):
    module = TintFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    editor = panel.editors["tint"]
    assert type(editor) is colour_editors
    assert editor.line.text() == "#ff8000" and "background-color: #ff8000" in editor.swatch.styleSheet()
    assert "type #rrggbb, a name" in editor.toolTip() and "the colour blended in" in editor.toolTip()
    type_into(qtbot, editor.line, "blue")
    assert module.tint == "#0000ff" and editor.line.text() == "#0000ff"
    module.tint = "#102030"  # the binding shows a change made elsewhere
    assert editor.line.text() == "#102030" and "#102030" in editor.swatch.styleSheet()
    panel.detach()


def test_text_the_plugin_type_refuses_is_reported_and_the_editor_snaps_back(qtbot, colour_editors):
    module = TintFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    errors: list[str] = []
    panel.error.connect(errors.append)
    type_into(qtbot, panel.editors["tint"].line, "mauve")
    assert module.tint == "#ff8000" and panel.editors["tint"].line.text() == "#ff8000"
    assert errors == ["TintFilter: parameter tint='mauve' is invalid: expected a colour #rrggbb in lower case "
                      "(e.g. #ff8000)"]
    panel.detach()


def test_without_its_editor_a_plugin_type_is_shown_read_only(qtbot):
    panel = ParameterPanel(TintFilter())
    qtbot.addWidget(panel)
    assert type(panel.editors["tint"]) is ReadOnlyEditor and panel.editors["tint"].label.text() == "'#ff8000'"
    panel.detach()


def test_editors_are_found_along_the_mro_and_a_subclass_may_register_its_own(qtbot):
    class Percent(Int):
        """An Int subclass: Int's editor unless it registers one."""

    class Name(Str):
        pass

    percent = Percent(5, "a share", min=0, max=100).bind("share", "X")
    editor = editor_for(percent)
    qtbot.addWidget(editor)
    assert type(editor) is NumberEditor and editor.slider.maximum() == 100
    assert type(editor_for(Name("x").bind("n", "X"))) is TextEditor

    class PercentEditor(ReadOnlyEditor):
        pass

    register_editor(Percent, PercentEditor)
    try:
        editor = editor_for(percent)
        qtbot.addWidget(editor)
        assert type(editor) is PercentEditor
    finally:
        unregister_editor(Percent)
    assert type(editor_for(percent)) is NumberEditor


@pytest.mark.parametrize("bad", [int, "NumberEditor"])
def test_register_editor_refuses_what_is_not_a_parameter_class_or_factory(bad):
    with pytest.raises(TypeError):
        if bad is int:
            register_editor(int, NumberEditor)
        else:
            register_editor(Colour, bad)


def test_an_optional_parameter_gets_a_none_box(qtbot):
    module = TintFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    editor = panel.editors["ceiling"]
    assert isinstance(editor, OptionalEditor) and isinstance(editor.inner, NumberEditor)
    assert isinstance(editor, ParameterEditor) and "none" in editor.toolTip()
    assert editor.none.isChecked() and not editor.inner.isEnabled()
    editor.none.setChecked(False)  # the user unticks "none": the inner editor's value is sent
    assert module.ceiling == 1 and editor.inner.isEnabled()
    editor.inner.spin.setValue(200)
    assert module.ceiling == 200
    editor.none.setChecked(True)
    assert module.ceiling is None and not editor.inner.isEnabled()
    editor.none.setChecked(False)  # the last value comes back
    assert module.ceiling == 200
    module.ceiling = None  # shown when set elsewhere
    assert editor.none.isChecked() and editor.inner.spin.value() == 200
    panel.detach()


def test_an_open_bound_keeps_the_spin_box_and_slider_inside(qtbot):
    class Open(Filter):
        kind = "2d"
        share = Float(0.5, "above 0, at most 1", min=0.0, min_open=True, max=1.0, step=0.05)
        count = Int(5, "1 to 9", min=0, min_open=True, max=10, max_open=True)

        def filter(self, frame):
            return frame

    module = Open()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    share, count = panel.editors["share"], panel.editors["count"]
    finest = 10.0 ** -share.spin.decimals()  # 0.001: one decimal finer than the step of 0.05
    assert finest == pytest.approx(0.001)
    assert share.spin.minimum() == pytest.approx(finest) and share.spin.maximum() == 1.0
    assert share.value_at(0) == pytest.approx(finest) and share.value_at(share.slider.maximum()) == 1.0
    share.slider.setValue(0)
    assert module.share == pytest.approx(finest)
    assert (count.spin.minimum(), count.spin.maximum()) == (1, 9)
    assert (count.value_at(0), count.value_at(count.slider.maximum())) == (1, 9)
    panel.detach()
