"""Generated parameter panels and their Document-View binding: widget -> setter, module notifies, panel
redraws from the getters; slider drags coalesced; a module type's own panel through the hook."""

from __future__ import annotations

import threading

import pytest
from PySide6.QtWidgets import QCheckBox, QComboBox, QLineEdit, QWidget

from objrec2d import HSVFilter, MorphologyFilter
from objrec_apps.gui import ParameterPanel, create_panel, register_panel, unregister_panel
from objrec_apps.gui.param_widgets import BoolEditor, ChoiceEditor, NumberEditor, TextEditor
from objrec_core import Bool, Choice, Filter, Float, Int, Str, module_types


class Everything(Filter):
    """A module with one parameter of every declared type."""

    count = Int(3, "a bounded int", min=0, max=10)
    odd = Int(5, "odd only", min=1, max=31, step=2)
    unbounded = Int(7, "no bounds")
    ratio = Float(0.5, "a bounded float", min=0.0, max=1.0, step=0.05)
    scale = Float(2.0, "bounded below only", min=0.0)
    enabled = Bool(True, "a switch")
    mode = Choice("fast", ["fast", "exact", "both"], "a choice")
    caption = Str("hello", "free text")

    def filter(self, frame):
        return frame


def notifications(module) -> list[dict]:
    seen: list[dict] = []
    module.watch(lambda m: seen.append(m.get_parameters()))
    return seen


@pytest.mark.parametrize("type_name", sorted(module_types()))
def test_a_panel_is_generated_for_every_registered_module_type(qtbot, type_name):
    klass = module_types()[type_name]
    module = klass()
    panel = create_panel(module)
    qtbot.addWidget(panel)
    assert isinstance(panel, ParameterPanel)
    assert module.id in panel.title()
    specs = module.parameter_specs()
    assert list(panel.editors) == [s.name for s in specs]
    values = module.get_parameters()
    for spec in specs:
        editor = panel.editors[spec.name]
        assert spec.doc and spec.doc in editor.toolTip()
        if isinstance(spec, Int | Float):
            assert isinstance(editor, NumberEditor)
            assert editor.spin.value() == pytest.approx(values[spec.name], abs=10 ** -editor.spin.decimals()
                                                        if isinstance(spec, Float) else 0)
            assert (editor.slider is not None) == (spec.min is not None and spec.max is not None)
        elif isinstance(spec, Bool):
            assert isinstance(editor, BoolEditor) and editor.check.isChecked() is values[spec.name]
        elif isinstance(spec, Choice):
            assert isinstance(editor, ChoiceEditor)
            assert [editor.combo.itemText(i) for i in range(editor.combo.count())] == list(spec.choices)
            assert editor.combo.currentText() == values[spec.name]
        else:
            assert isinstance(editor, TextEditor)
    panel.detach()


def test_every_parameter_type_gets_its_widget(qtbot):
    module = Everything()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    e = panel.editors
    assert e["count"].slider.maximum() == 10 and e["count"].slider.value() == 3
    assert e["odd"].slider.maximum() == 15  # (31 - 1) / 2 positions above 1
    assert e["unbounded"].slider is None and e["unbounded"].spin.value() == 7
    assert e["ratio"].slider.maximum() == 20 and e["ratio"].slider.value() == 10
    assert e["scale"].slider is None
    assert isinstance(e["enabled"].findChild(QCheckBox), QCheckBox)
    assert isinstance(e["mode"].findChild(QComboBox), QComboBox)
    assert e["caption"].findChild(QLineEdit).text() == "hello"
    panel.detach()


def test_moving_a_slider_sets_the_parameter_honouring_the_step(qtbot):
    module = MorphologyFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    editor = panel.editors["kernel_size"]
    editor.slider.setValue(3)  # positions count steps of 2 from 1: 1, 3, 5, 7
    qtbot.waitUntil(lambda: module.kernel_size == 7)
    assert editor.spin.value() == 7
    panel.editors["iterations"].slider.setValue(4)
    qtbot.waitUntil(lambda: module.iterations == 4)
    panel.editors["operation"].combo.setCurrentText("close")
    assert module.operation == "close"
    panel.detach()


def test_a_typed_value_is_snapped_to_the_declared_step(qtbot):
    module = MorphologyFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    panel.editors["kernel_size"].spin.setValue(8)  # even: not allowed; the nearest step up is 9
    assert module.kernel_size == 9
    assert panel.editors["kernel_size"].slider.value() == 4
    panel.detach()


def test_a_change_from_code_moves_the_slider_at_once(qtbot):
    module = HSVFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    module.set_parameters(h_min=42, s_min=130)
    assert panel.editors["h_min"].slider.value() == 42 and panel.editors["h_min"].spin.value() == 42
    assert panel.editors["s_min"].slider.value() == 130
    module.h_max = 100
    assert panel.editors["h_max"].slider.value() == 100
    panel.detach()


def test_a_change_from_another_thread_reaches_the_panel_through_the_event_loop(qtbot):
    module = HSVFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    thread = threading.Thread(target=lambda: module.set_parameters(v_min=77))
    thread.start()
    thread.join()
    qtbot.waitUntil(lambda: panel.editors["v_min"].slider.value() == 77)
    panel.detach()


def test_a_slider_drag_is_coalesced(qtbot):
    module = HSVFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    seen = notifications(module)
    slider = panel.editors["h_max"].slider
    slider.setSliderDown(True)
    for position in range(179, 59, -1):  # a drag across 120 positions, faster than the throttle interval
        slider.setValue(position)
    slider.setSliderDown(False)  # release: the last position is sent at once
    assert module.h_max == 60
    assert 2 <= len(seen) <= 4, f"{len(seen)} updates for one drag"
    assert seen[0]["h_max"] == 178 and seen[-1]["h_max"] == 60
    panel.detach()


def test_restore_defaults_and_a_refused_value(qtbot):
    module = Everything(count=9, mode="exact")
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    panel.restore_button.click()
    assert module.get_parameters() == Everything().get_parameters()
    assert panel.editors["count"].slider.value() == 3
    errors: list[str] = []
    panel.error.connect(errors.append)
    panel._edited("count", 99)  # what a widget would send if its range were wrong
    assert module.count == 3 and errors and "count=99" in errors[0]
    panel.detach()


def test_a_detached_panel_no_longer_observes(qtbot):
    module = HSVFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    assert len(module.observers) == 1
    panel.detach()
    assert module.observers == ()


def test_a_module_type_can_register_its_own_panel(qtbot):
    class OwnPanel(QWidget):
        def __init__(self, module):
            super().__init__()
            self.module = module

    register_panel("Everything", OwnPanel)
    try:
        panel = create_panel(Everything())
        qtbot.addWidget(panel)
        assert isinstance(panel, OwnPanel)
    finally:
        unregister_panel("Everything")
    generated = create_panel(Everything())
    qtbot.addWidget(generated)
    assert isinstance(generated, ParameterPanel)
    generated.detach()


def test_the_feature_detector_has_its_own_panel_with_the_target(qtbot):
    feature = pytest.importorskip("objrec2d.feature_detector")
    import numpy as np

    from objrec2d import DemoScene
    from objrec_apps.gui.feature_panel import FeatureDetectorPanel
    from objrec_core import Rect

    detector = feature.FeatureDetector()
    panel = create_panel(detector)
    qtbot.addWidget(panel)
    assert isinstance(panel, FeatureDetectorPanel)
    assert panel.thumbnail.pixmap().isNull() and not panel.clear_button.isEnabled()
    scene = DemoScene()
    image, _ = scene.render(0)
    x, y, w, h = scene.target.reference_rect
    detector.process_area_selection(Rect(x, y, w, h), image)
    assert not panel.thumbnail.pixmap().isNull()
    assert f"{w}×{h} px selected at ({x}, {y})" in panel.info.text()
    assert f"{len(detector.target)} ORB keypoints" in panel.info.text()
    panel.clear_button.click()
    assert detector.target is None and panel.thumbnail.pixmap().isNull()
    assert np.asarray(image).shape == (480, 640, 3)
    panel.detach()
