"""Generated parameter panels and their Document-View binding: widget -> setter, module notifies with the
changes, the panel shows the changed values from the getters; slider drags coalesced; sliders over the soft
range, spin boxes over the hard bounds storing typed values exactly; only relevant parameters shown, only
available choices offered; a module type's own panel through the hook."""

from __future__ import annotations

import threading

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QCheckBox, QComboBox, QLineEdit, QWidget

from objrec2d import HSVFilter, MorphologyFilter
from objrec_apps.gui import ParameterPanel, create_panel, register_panel, unregister_panel
from objrec_apps.gui.param_widgets import (
    INT_LIMIT,
    BoolEditor,
    ChoiceEditor,
    NumberEditor,
    OptionalEditor,
    TextEditor,
)
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


class Soft(Filter):
    """Numbers whose slider (soft) range is narrower than what validation allows."""

    level = Int(50, "slider 0..100, allowed 0..1000", min=0, max=1000, soft_max=100)
    gain = Float(1.0, "slider 0..2, allowed 0..10, no step declared", min=0.0, max=10.0, soft_max=2.0)
    offset = Float(0.0, "slider -1..1, open above", min=-5.0, soft_min=-1.0)
    width = Int(5, "odd, slider 1..21, allowed 1..99", min=1, max=99, soft_max=21, step=2)

    def filter(self, frame):
        return frame


class Modes(Filter):
    """Parameters that matter only with some values of others."""

    method = Choice("box", ["box", "gauss", "median"], "how to smooth")
    box_size = Int(3, "box only", min=1, max=31, relevant={"method": ("box",)})
    sigma = Float(1.0, "gauss only", min=0.1, max=10.0, step=0.1, relevant=lambda v: v["method"] == "gauss")
    passes = Int(1, "box and median", min=1, max=5, relevant={"method": ("box", "median")})
    backend = Choice("cpu", ["cpu", "gpu", "fpga"], "where it runs",
                     unavailable=lambda: {"gpu": "no GPU found", "fpga": "no FPGA driver"})

    def filter(self, frame):
        return frame


def notifications(module) -> list[dict]:
    seen: list[dict] = []
    module.watch(lambda changes: seen.append(module.get_parameters()))
    return seen


def type_into(qtbot, spin, text: str) -> None:
    """Select the spin box's text, type ``text`` and press Enter, as a user does."""
    spin.selectAll()
    qtbot.keyClicks(spin, text)
    qtbot.keyClick(spin, Qt.Key.Key_Return)


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
        if spec.optional:  # the type's editor, inside a "none" box
            assert isinstance(editor, OptionalEditor) and editor.none.isChecked() is (values[spec.name] is None)
            if values[spec.name] is None:
                continue
            editor = editor.inner
        if isinstance(spec, Int | Float):
            assert isinstance(editor, NumberEditor)
            assert editor.spin.value() == pytest.approx(values[spec.name], abs=10 ** -editor.spin.decimals()
                                                        if isinstance(spec, Float) else 0)
            assert (editor.slider is not None) == (spec.slider_range is not None)
            if editor.slider is not None:
                assert editor.value_at(0) == pytest.approx(spec.slider_range[0], abs=spec.enforced_step or 1e-9)
                assert editor.value_at(editor.slider.maximum()) == pytest.approx(spec.slider_range[1],
                                                                                 abs=spec.enforced_step or 1e-9)
        elif isinstance(spec, Bool):
            assert isinstance(editor, BoolEditor) and editor.check.isChecked() is values[spec.name]
        elif isinstance(spec, Choice):
            assert isinstance(editor, ChoiceEditor)
            assert [editor.combo.itemText(i) for i in range(editor.combo.count())] == list(spec.available_choices)
            assert editor.combo.currentText() == values[spec.name]
        else:
            assert isinstance(editor, TextEditor)
    assert panel.shown_parameters == module.relevant_parameters()
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


def test_a_typed_value_is_stored_exactly(qtbot):
    shape = pytest.importorskip("objrec3d.shape_detector")
    plane = pytest.importorskip("objrec3d.plane_removal_filter")
    detector = shape.ShapeDetector()
    panel = ParameterPanel(detector)
    qtbot.addWidget(panel)
    type_into(qtbot, panel.editors["min_inliers"].spin, "1234")
    assert detector.min_inliers == 1234
    assert panel.editors["min_inliers"].spin.value() == 1234
    panel.detach()
    remover = plane.PlaneRemovalFilter()
    panel = ParameterPanel(remover)
    qtbot.addWidget(panel)
    type_into(qtbot, panel.editors["min_plane_points"].spin, "2500")
    assert remover.min_plane_points == 2500
    type_into(qtbot, panel.editors["min_plane_points"].spin, "9999999")  # the hard maximum is 10,000,000
    assert remover.min_plane_points == 9_999_999
    panel.detach()


def test_sliders_cover_the_soft_range_and_spin_boxes_the_hard_bounds(qtbot):
    module = Soft()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    level, gain, offset, width = (panel.editors[n] for n in ("level", "gain", "offset", "width"))
    assert level.slider.maximum() == 100 and level.value_at(100) == 100
    assert (level.spin.minimum(), level.spin.maximum(), level.spin.singleStep()) == (0, 1000, 1)
    assert gain.value_at(gain.slider.maximum()) == 2.0 and (gain.spin.minimum(), gain.spin.maximum()) == (0.0, 10.0)
    assert gain.spin.singleStep() == pytest.approx(0.02)  # no declared step: a round fraction of the soft range
    assert offset.slider is None and offset.spin.minimum() == -5.0 and offset.spin.maximum() >= 1e9  # open side
    assert width.slider.maximum() == 10 and width.spin.singleStep() == 2 and width.spin.maximum() == 99
    unbounded = ParameterPanel(Everything())
    qtbot.addWidget(unbounded)
    spin = unbounded.editors["unbounded"].spin
    assert (spin.minimum(), spin.maximum(), spin.singleStep()) == (-INT_LIMIT, INT_LIMIT, 1)
    assert unbounded.editors["ratio"].spin.singleStep() == 0.05  # the declared float step
    unbounded.detach()

    type_into(qtbot, level.spin, "750")  # past the soft maximum, inside the hard one: stored, slider pinned
    assert module.level == 750 and level.slider.value() == level.slider.maximum()
    type_into(qtbot, gain.spin, "7.25")
    assert module.gain == 7.25 and gain.slider.value() == gain.slider.maximum()
    type_into(qtbot, width.spin, "55")  # odd, past the soft maximum 21
    assert module.width == 55 and width.slider.value() == width.slider.maximum()
    type_into(qtbot, width.spin, "56")  # even: the nearest allowed value
    assert module.width == 57
    type_into(qtbot, offset.spin, "250.5")
    assert module.offset == 250.5
    module.level = 40  # a value inside the soft range moves the slider back
    assert level.slider.value() == 40 and level.spin.value() == 40
    level.slider.setValue(100)
    level.throttle.flush()
    assert module.level == 100
    panel.detach()


def test_only_relevant_parameters_are_shown(qtbot):
    module = Modes()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    panel.show()
    qtbot.waitExposed(panel)

    def visible() -> list[str]:
        return [name for name, editor in panel.editors.items() if editor.isVisible()]

    assert panel.shown_parameters == visible() == ["method", "box_size", "passes", "backend"]
    panel.editors["method"].combo.setCurrentText("gauss")
    assert module.method == "gauss"
    assert panel.shown_parameters == visible() == ["method", "sigma", "backend"]
    assert not panel.form.labelForField(panel.editors["box_size"]).isVisible()  # the whole row goes
    module.method = "median"  # from code: re-evaluated as well
    assert panel.shown_parameters == visible() == ["method", "passes", "backend"]
    module.set_parameters(box_size=9)  # a hidden parameter keeps its value and its editor follows it
    assert panel.editors["box_size"].spin.value() == 9 and "box_size" not in visible()
    assert "only when method is box" in panel.editors["box_size"].toolTip()
    panel.detach()


def test_an_unavailable_choice_is_not_offered(qtbot):
    module = Modes()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    combo = panel.editors["backend"].combo
    assert [combo.itemText(i) for i in range(combo.count())] == ["cpu"]
    assert "gpu (no GPU found)" in panel.editors["backend"].toolTip()
    errors: list[str] = []
    panel.error.connect(errors.append)
    panel._edited("backend", "gpu")  # what a widget offering it would send
    assert module.backend == "cpu" and len(errors) == 1 and "no GPU found" in errors[0]
    panel.detach()


def test_the_feature_detector_shows_the_settings_of_its_feature_type(qtbot):
    feature = pytest.importorskip("objrec2d.feature_detector")
    detector = feature.FeatureDetector()
    if "SIFT" not in detector.parameter_spec("feature_type").available_choices:
        pytest.skip("this OpenCV has no SIFT")
    panel = ParameterPanel(detector)
    qtbot.addWidget(panel)
    orb = [name for name in panel.editors if name.startswith("orb_")]
    sift = [name for name in panel.editors if name.startswith("sift_")]
    assert orb and sift
    assert set(orb) <= set(panel.shown_parameters) and not set(sift) & set(panel.shown_parameters)
    panel.editors["feature_type"].combo.setCurrentText("SIFT")
    assert detector.feature_type == "SIFT"
    assert set(sift) <= set(panel.shown_parameters) and not set(orb) & set(panel.shown_parameters)
    assert panel.shown_parameters == detector.relevant_parameters()
    panel.detach()


def test_a_change_redraws_only_the_editors_it_names(qtbot, monkeypatch):
    module = HSVFilter()
    panel = ParameterPanel(module)
    qtbot.addWidget(panel)
    shown: list[tuple[str, object]] = []
    for name, editor in panel.editors.items():
        original = editor.show_value
        monkeypatch.setattr(editor, "show_value",
                            lambda value, n=name, f=original: (shown.append((n, value)), f(value)))
    module.set_parameters(h_min=42, s_min=130)
    assert sorted(shown) == [("h_min", 42), ("s_min", 130)]
    shown.clear()
    module.set_parameters(h_min=42)  # no change: no notification, nothing redrawn
    assert shown == []
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
    assert panel.editors["count"].spin.value() == 3
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
