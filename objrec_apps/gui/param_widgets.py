"""One editor widget per declared parameter type, generated from the declaration alone.

Editors never touch a module: they emit ``edited(name, value)`` and show what they are told with
``show_value`` (the panel's Document-View binding does both). Slider drags go through a ``Throttle`` so a
drag across the range sends a handful of updates, not hundreds.

A number gets a slider over its soft range (``spec.slider_range``) and a spin box over its hard bounds: the
slider is for tuning within the usual values, the spin box for any value the declaration allows, stored as
typed (an Int with an enforced step takes the nearest allowed value). A value past the soft range pins the
slider at that end.

Which editor a declaration gets is a registry keyed by parameter class, looked up along the class's MRO
(as magicgui registers widgets by type): ``register_editor(Colour, ColourEditor)`` in a plug-in gives its
parameter type an editor, and a subclass of ``Int`` gets ``Int``'s editor unless it registers its own. The
built-in editors are registered the same way, at the end of this module. An optional parameter's editor is
wrapped in ``OptionalEditor``: a "none" check box beside it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QEvent, QObject, QSignalBlocker, Qt, QTimer, Signal
from PySide6.QtGui import QKeyEvent, QKeySequence
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QSlider,
    QSpinBox,
    QWidget,
)

from objrec_core import Bool, Choice, Float, Int, Parameter, Str

#: At most one update per this many milliseconds while a slider is dragged.
THROTTLE_MS = 40
#: Most positions a slider has: finer steps over a wide soft range are coarsened (typing stays exact).
MAX_SLIDER_POSITIONS = 100_000
#: Positions a float slider without a declared step aims for.
FLOAT_SLIDER_POSITIONS = 1000
#: Spin-box steps across the soft range for a float without a declared step.
FLOAT_SPIN_STEPS = 100
#: QSpinBox holds a 32-bit int: the widest range an Int's spin box can offer.
INT_LIMIT = 2**31 - 1
#: What a float's spin box offers on an open side.
FLOAT_LIMIT = 1e12
#: Most decimals a float's spin box shows.
MAX_DECIMALS = 8

_NOTHING = object()

#: The keys of the window's Edit > Undo and Redo, which a spin box's own text undo must not swallow.
WINDOW_UNDO_KEYS = (QKeySequence.StandardKey.Undo, QKeySequence.StandardKey.Redo)


class WindowUndoKeys(QObject):
    """An event filter for a spin box: Ctrl+Z and Ctrl+Shift+Z go to the window's undo and redo. A
    spin box's text undo would only undo keystrokes of a value it has already applied, and by
    taking the keys it left the window's Undo dead while a spin box had the focus."""

    def eventFilter(self, watched: QObject, event: QEvent) -> bool:  # noqa: N802 - Qt override
        if event.type() == QEvent.Type.ShortcutOverride and isinstance(event, QKeyEvent):
            control_z = event.key() == Qt.Key.Key_Z and bool(event.modifiers() & Qt.KeyboardModifier.ControlModifier)
            if control_z or any(event.matches(key) for key in WINDOW_UNDO_KEYS):
                event.ignore()  # not overridden: the shortcut (the window's action) fires
                return True
        return False


class Throttle(QObject):
    """Passes the first value on at once, then at most one (the latest) per interval.

    Leading and trailing edge: the first movement of a slider shows at once, the final position always
    arrives, and nothing in between floods the pipeline.
    """

    def __init__(self, apply: Callable[[Any], None], interval_ms: int = THROTTLE_MS, parent: QObject | None = None):
        super().__init__(parent)
        self._apply = apply
        self._pending: Any = _NOTHING
        self._timer = QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.setInterval(interval_ms)
        self._timer.timeout.connect(self._flush)

    def push(self, value: Any) -> None:
        if self._timer.isActive():
            self._pending = value
            return
        self._apply(value)
        self._timer.start()

    def flush(self) -> None:
        """Send what is waiting now (on slider release)."""
        self._timer.stop()
        self._flush()

    def cancel(self) -> None:
        """Forget what is waiting (a typed value replaces it)."""
        self._pending = _NOTHING

    def _flush(self) -> None:
        value, self._pending = self._pending, _NOTHING
        if value is not _NOTHING:
            self._apply(value)
            self._timer.start()


class ParameterEditor(QWidget):
    """Base of the editors: knows its declaration, emits the user's edits.

    A plug-in's editor subclasses this, builds its widgets in ``__init__``, implements ``show_value`` and
    calls ``_emit(value)`` when the user edits; ``tooltip_details`` adds lines to the tooltip.
    """

    edited = Signal(str, object)

    def __init__(self, spec: Parameter, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.spec = spec
        self.setToolTip(tooltip(spec, self.tooltip_details()))
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)

    def show_value(self, value: Any) -> None:
        """Display ``value`` without emitting ``edited``."""
        raise NotImplementedError

    def tooltip_details(self) -> list[str]:
        """Lines this kind of editor adds to the tooltip (called before the editor's own widgets exist)."""
        return []

    def _emit(self, value: Any) -> None:
        self.edited.emit(self.spec.name, value)


def _number_text(value: float) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}"


def tooltip(spec: Parameter, details: list[str] | tuple[str, ...] = ()) -> str:
    """The declaration's description, its allowed values, what the editor adds (the slider's range where
    narrower, choices not available here), and when the parameter matters."""
    default = "none" if spec.default is None else repr(spec.default)
    lines = [spec.doc or spec.name, f"{spec.name}: {spec.describe()}, default {default}", *details]
    relevance = spec.relevance_text()
    if relevance:
        lines.append(f"matters {relevance}")
    return "\n".join(lines)


def nice_step(value: float, *, up: bool = False) -> float:
    """The 1, 2 or 5 times a power of ten nearest below (``up``: above) ``value``."""
    if value <= 0 or not math.isfinite(value):
        return 1.0
    exponent = math.floor(math.log10(value))
    candidates = [m * 10.0**e for e in (exponent - 1, exponent, exponent + 1) for m in (1, 2, 5)]
    if up:
        return min(c for c in candidates if c >= value * (1 - 1e-9))
    return max(c for c in candidates if c <= value * (1 + 1e-9))


def spin_step(spec: Int | Float) -> float:
    """The spin box's arrow step: an Int's enforced step (else 1); a Float's declared step, else a round
    fraction of its soft range (else of its default's size)."""
    if isinstance(spec, Int):
        return float(spec.enforced_step or 1)
    if spec.step:
        return float(spec.step)
    soft = spec.slider_range
    if soft is not None and soft[1] > soft[0]:
        return nice_step((soft[1] - soft[0]) / FLOAT_SPIN_STEPS)
    return nice_step(abs(spec.default) / 10) if spec.default else 0.1


def exact_decimals(value: float) -> int:
    """The fewest decimals that write ``value`` exactly (up to MAX_DECIMALS)."""
    for decimals in range(MAX_DECIMALS + 1):
        if abs(round(value, decimals) - value) <= 1e-12 * max(1.0, abs(value)):
            return decimals
    return MAX_DECIMALS


def float_decimals(spec: Float, step: float) -> int:
    """Enough decimals for one digit finer than the step and for every declared number, exactly."""
    finer = math.ceil(-math.log10(step)) + 1 if step > 0 else 3
    declared = [v for v in (spec.min, spec.max, spec.soft_min, spec.soft_max, spec.default, spec.step)
                if v is not None]
    return min(MAX_DECIMALS, max(1, finer, *(exact_decimals(float(v)) for v in declared)))


class NumberEditor(ParameterEditor):
    """A slider over the soft range with a spin box over the hard bounds for an Int or Float (a spin box
    alone where the soft range is open on a side).

    The slider moves in the declaration's steps (odd kernel sizes stay odd), coarsened where the soft range
    has more than MAX_SLIDER_POSITIONS of them. A value typed into the spin box is sent as typed: only an
    Int with an enforced step is moved to the nearest allowed value.
    """

    def __init__(self, spec: Int | Float, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.is_int = isinstance(spec, Int)
        self.step = spin_step(spec)
        self.decimals = 0 if self.is_int else float_decimals(spec, self.step)
        #: The lowest and highest values the spin box offers: the hard bounds, an open one moved inside by
        #: the smallest amount the box can show.
        self.lowest, self.highest = self._inside_bounds(spec)
        self.slider: QSlider | None = None
        self.slider_low = self.slider_high = self.slider_step = self._origin = 0.0
        self._first = self._inner = 0
        self._make_slider(spec)
        self.throttle = Throttle(self._emit, parent=self)
        if self.is_int:
            spin: QSpinBox | QDoubleSpinBox = QSpinBox()
            spin.setRange(max(int(self.lowest), -INT_LIMIT), min(int(self.highest), INT_LIMIT))
            spin.setSingleStep(int(self.step))
        else:
            spin = QDoubleSpinBox()
            spin.setDecimals(self.decimals)
            spin.setRange(self.lowest, self.highest)
            spin.setSingleStep(self.step)
        spin.setKeyboardTracking(False)  # typing "120" sends 120, not 1, 12 and 120
        spin.setMinimumWidth(80)
        spin.valueChanged.connect(self._spin_changed)
        self._undo_keys = WindowUndoKeys(spin)
        spin.installEventFilter(self._undo_keys)
        self.spin = spin
        self.layout().addWidget(spin)

    def tooltip_details(self) -> list[str]:
        spec = self.spec
        soft = spec.slider_range
        if soft is not None and (soft[0] != spec.min or soft[1] != spec.max):
            return [f"the slider covers {_number_text(soft[0])}..{_number_text(soft[1])}; type a value beyond it "
                    "into the box"]
        return []

    def _inside_bounds(self, spec: Int | Float) -> tuple[float, float]:
        """The spin box's range: the hard bounds (else the widest it holds), an excluded one moved inside by
        one (Int) or by the last decimal shown (Float)."""
        limit = INT_LIMIT if self.is_int else FLOAT_LIMIT
        nudge = 1 if self.is_int else 10.0 ** -self.decimals
        low = -limit if spec.min is None else spec.min + (nudge if spec.min_open else 0)
        high = limit if spec.max is None else spec.max - (nudge if spec.max_open else 0)
        return low, high

    def _make_slider(self, spec: Int | Float) -> None:
        """The slider's positions: the soft minimum, the multiples of the step strictly inside the soft range
        (counted from the minimum for an Int with an enforced step, from zero otherwise, so they are round),
        then the soft maximum."""
        soft = spec.slider_range
        if soft is None:
            return
        low, high = max(float(soft[0]), self.lowest), min(float(soft[1]), self.highest)
        if self.is_int:
            enforced = spec.enforced_step or 1
            origin = float(spec.step_origin if spec.enforced_step else 0)
            if spec.enforced_step:  # the ends themselves must be allowed values
                low = origin + math.ceil((low - origin) / enforced) * enforced
                high = origin + math.floor((high - origin) / enforced) * enforced
            step = float(enforced * max(1, math.ceil((high - low) / enforced / MAX_SLIDER_POSITIONS)))
        else:
            origin = 0.0
            step = float(spec.step) if spec.step else nice_step((high - low) / FLOAT_SLIDER_POSITIONS)
            if (high - low) / step > MAX_SLIDER_POSITIONS:
                step = nice_step((high - low) / MAX_SLIDER_POSITIONS, up=True)
        if high <= low:
            return
        first = math.floor((low - origin) / step + 1e-9) + 1  # the first multiple above the soft minimum
        last = math.ceil((high - origin) / step - 1e-9) - 1  # the last one below the soft maximum
        self._origin, self._first, self._inner = origin, first, max(0, last - first + 1)
        self.slider_low, self.slider_high, self.slider_step = low, high, step
        positions = self._inner + 1
        self.slider = QSlider(Qt.Orientation.Horizontal)
        self.slider.setRange(0, positions)
        self.slider.setSingleStep(1)
        self.slider.setPageStep(max(1, positions // 10))
        self.slider.valueChanged.connect(self._slider_moved)
        self.slider.sliderReleased.connect(self._slider_released)
        self.layout().addWidget(self.slider, 1)

    # slider position <-> value
    def value_at(self, position: int) -> int | float:
        """The value at a slider position: the soft minimum, a multiple of the step, or the soft maximum."""
        if position <= 0:
            value = self.slider_low
        elif position > self._inner:
            value = self.slider_high
        else:
            value = self._origin + (self._first + position - 1) * self.slider_step
        return round(value) if self.is_int else round(value, self.decimals)

    def position_of(self, value: float) -> int:
        """The slider position nearest ``value``; one past the soft range pins the slider at that end."""
        if self.slider is None:
            return 0
        guess = round((value - self._origin) / self.slider_step) - self._first + 1
        candidates = {min(max(p, 0), self._inner + 1) for p in (guess - 1, guess, guess + 1)}
        return min(sorted(candidates), key=lambda p: abs(self.value_at(p) - value))

    def snap(self, value: float) -> int | float:
        """The value a typed number stands for: itself, or for an Int with an enforced step the nearest
        allowed value (steps count from the minimum, as the declaration does)."""
        if not self.is_int:
            return float(value)
        value = round(value)
        step = self.spec.enforced_step
        if step:
            base = self.spec.step_origin
            value = base + round((value - base) / step) * step
            if self.spec.above_max(value):
                value -= step
            if self.spec.below_min(value):
                value += step
        return int(value)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.spin):
            self.spin.setValue(value)
        if self.slider is not None:
            with QSignalBlocker(self.slider):
                self.slider.setValue(self.position_of(value))

    def _slider_moved(self, position: int) -> None:
        value = self.value_at(position)
        with QSignalBlocker(self.spin):
            self.spin.setValue(value)
        self.throttle.push(value)

    def _slider_released(self) -> None:
        self.throttle.flush()

    def _spin_changed(self, value: float) -> None:
        value = self.snap(value)
        if self.slider is not None:
            with QSignalBlocker(self.slider):
                self.slider.setValue(self.position_of(value))
        self.throttle.cancel()  # a typed value replaces any drag still waiting
        self._emit(value)


class BoolEditor(ParameterEditor):
    def __init__(self, spec: Bool, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.check = QCheckBox()
        self.check.toggled.connect(self._emit)
        self.layout().addWidget(self.check)
        self.layout().addStretch(1)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.check):
            self.check.setChecked(bool(value))


class ChoiceEditor(ParameterEditor):
    """A combo box of the choices this installation can serve (``spec.available_choices``)."""

    def __init__(self, spec: Choice, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.combo = QComboBox()
        self.combo.addItems(list(spec.available_choices))
        self.combo.currentTextChanged.connect(self._emit)
        self.layout().addWidget(self.combo, 1)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.combo):
            self.combo.setCurrentText(str(value))

    def tooltip_details(self) -> list[str]:
        missing = self.spec.unavailable
        return ["not available here: " + "; ".join(f"{c} ({why})" for c, why in missing.items())] if missing else []


class TextEditor(ParameterEditor):
    def __init__(self, spec: Str, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.line = QLineEdit()
        self.line.editingFinished.connect(lambda: self._emit(self.line.text()))
        self.layout().addWidget(self.line, 1)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.line):
            self.line.setText(str(value))


class ReadOnlyEditor(ParameterEditor):
    """For a parameter type this GUI does not know: shown, not editable."""

    def __init__(self, spec: Parameter, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.label = QLabel()
        self.layout().addWidget(self.label, 1)

    def show_value(self, value: Any) -> None:
        self.label.setText(repr(value))


class OptionalEditor(ParameterEditor):
    """An optional parameter's editor with a "none" check box beside it: checked, the value is None and the
    inner editor is disabled (it keeps the last value, which unchecking sends again)."""

    def __init__(self, spec: Parameter, inner: ParameterEditor, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.inner = inner
        self.setToolTip(inner.toolTip())
        self.none = QCheckBox("none")
        self.none.setToolTip(f"no value: {spec.doc or spec.name}")
        self._last: Any = spec.example()
        inner.show_value(self._last)
        inner.edited.connect(self._inner_edited)
        self.none.toggled.connect(self._none_toggled)
        self.layout().addWidget(inner, 1)
        self.layout().addWidget(self.none)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.none):
            self.none.setChecked(value is None)
        self.inner.setEnabled(value is not None)
        if value is not None:
            self._last = value
            self.inner.show_value(value)

    def _inner_edited(self, _name: str, value: Any) -> None:
        self._last = value
        self._emit(value)

    def _none_toggled(self, checked: bool) -> None:
        self.inner.setEnabled(not checked)
        self._emit(None if checked else self._last)


#: A factory makes the editor of one declaration: ``factory(spec, parent)``, usually the editor class.
EditorFactory = Callable[[Any, "QWidget | None"], ParameterEditor]
_editors: dict[type[Parameter], EditorFactory] = {}


def register_editor(parameter_class: type[Parameter], factory: EditorFactory) -> None:
    """Give ``parameter_class`` (and its subclasses, unless they have their own) the editor ``factory``.

    Registering again replaces the earlier editor, so a plug-in may also restyle a built-in type.
    """
    if not (isinstance(parameter_class, type) and issubclass(parameter_class, Parameter)):
        raise TypeError(f"register_editor: {parameter_class!r} is not a Parameter subclass")
    if not callable(factory):
        raise TypeError(f"register_editor: the editor of {parameter_class.__name__} is not callable")
    _editors[parameter_class] = factory


def unregister_editor(parameter_class: type[Parameter]) -> None:
    """Forget ``parameter_class``'s editor (its subclasses fall back along the MRO)."""
    _editors.pop(parameter_class, None)


def editor_factory(spec: Parameter) -> EditorFactory:
    """The registered factory nearest ``spec``'s class along its MRO; a read-only label for none."""
    for klass in type(spec).__mro__:
        factory = _editors.get(klass)
        if factory is not None:
            return factory
    return ReadOnlyEditor


def editor_for(spec: Parameter, parent: QWidget | None = None) -> ParameterEditor:
    """The widget for a declaration, from the registry; an optional one gets a "none" check box too."""
    editor = editor_factory(spec)(spec, None if spec.optional else parent)
    return OptionalEditor(spec, editor, parent) if spec.optional else editor


register_editor(Int, NumberEditor)
register_editor(Float, NumberEditor)
register_editor(Bool, BoolEditor)
register_editor(Choice, ChoiceEditor)
register_editor(Str, TextEditor)
