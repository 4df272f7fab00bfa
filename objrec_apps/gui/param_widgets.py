"""One editor widget per declared parameter type, generated from the declaration alone.

Editors never touch a module: they emit ``edited(name, value)`` and show what they are told with
``show_value`` (the panel's Document-View binding does both). Slider drags go through a ``Throttle`` so a
drag across the range sends a handful of updates, not hundreds.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QObject, QSignalBlocker, Qt, QTimer, Signal
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
#: Finest slider resolution for a float without a step.
MAX_SLIDER_POSITIONS = 100_000

_NOTHING = object()


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
    """Base of the editors: knows its declaration, emits the user's edits."""

    edited = Signal(str, object)

    def __init__(self, spec: Parameter, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.spec = spec
        self.setToolTip(tooltip(spec))
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)

    def show_value(self, value: Any) -> None:
        """Display ``value`` without emitting ``edited``."""
        raise NotImplementedError

    def _emit(self, value: Any) -> None:
        self.edited.emit(self.spec.name, value)


def tooltip(spec: Parameter) -> str:
    """The declaration's one-line description and its allowed values."""
    text = spec.doc or spec.name
    return f"{text}\n{spec.name}: {spec.describe()}, default {spec.default!r}"


def _decimals(step: float) -> int:
    return min(6, max(1, math.ceil(-math.log10(step)) + 1)) if step > 0 else 3


class NumberEditor(ParameterEditor):
    """A slider with a spin box for a bounded Int or Float (a spin box alone when unbounded).

    The slider moves in the declaration's steps (odd kernel sizes stay odd); a value typed into the spin box
    is snapped to the nearest step before it is sent.
    """

    def __init__(self, spec: Int | Float, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.is_int = isinstance(spec, Int)
        self.low = spec.min
        self.high = spec.max
        bounded = self.low is not None and self.high is not None
        if spec.step:
            self.step = float(spec.step)
        elif self.is_int:
            self.step = 1.0
        elif bounded:
            self.step = (self.high - self.low) / 1000 or 1.0
        else:
            self.step = 0.1
        if bounded and (self.high - self.low) / self.step > MAX_SLIDER_POSITIONS:
            self.step = (self.high - self.low) / MAX_SLIDER_POSITIONS
        self.slider: QSlider | None = None
        if bounded:
            self.slider = QSlider(Qt.Orientation.Horizontal)
            self.slider.setRange(0, round((self.high - self.low) / self.step))
            self.slider.setSingleStep(1)
            self.slider.setPageStep(max(1, self.slider.maximum() // 10))
            self.slider.valueChanged.connect(self._slider_moved)
            self.slider.sliderReleased.connect(self._slider_released)
            self.layout().addWidget(self.slider, 1)
        self.throttle = Throttle(self._emit, parent=self)
        if self.is_int:
            spin: QSpinBox | QDoubleSpinBox = QSpinBox()
            spin.setRange(int(self.low) if self.low is not None else -(2**31) + 1,
                          int(self.high) if self.high is not None else 2**31 - 1)
            spin.setSingleStep(int(self.step))
        else:
            spin = QDoubleSpinBox()
            spin.setDecimals(_decimals(float(spec.step) if spec.step else self.step))
            spin.setRange(self.low if self.low is not None else -1e12, self.high if self.high is not None else 1e12)
            spin.setSingleStep(self.step)
        spin.setKeyboardTracking(False)  # typing "120" sends 120, not 1, 12 and 120
        spin.setMinimumWidth(80)
        spin.valueChanged.connect(self._spin_changed)
        self.spin = spin
        self.layout().addWidget(spin)

    # slider position <-> value
    def value_at(self, position: int) -> int | float:
        value = (self.low or 0) + position * self.step
        return round(value) if self.is_int else round(value, 9)

    def position_of(self, value: float) -> int:
        return round((value - (self.low or 0)) / self.step)

    def snap(self, value: float) -> int | float:
        """The nearest allowed value (Int steps count from the minimum, as the declaration does)."""
        if self.is_int and self.step != 1:
            base = self.low or 0
            value = base + round((value - base) / self.step) * self.step
            if self.high is not None and value > self.high:
                value -= self.step
        return round(value) if self.is_int else float(value)

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
    def __init__(self, spec: Choice, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.combo = QComboBox()
        self.combo.addItems(list(spec.choices))
        self.combo.currentTextChanged.connect(self._emit)
        self.layout().addWidget(self.combo, 1)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.combo):
            self.combo.setCurrentText(str(value))


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


def editor_for(spec: Parameter, parent: QWidget | None = None) -> ParameterEditor:
    """The widget for a declaration: slider + spin box, check box, combo box or text field."""
    if isinstance(spec, Int | Float):
        return NumberEditor(spec, parent)
    if isinstance(spec, Bool):
        return BoolEditor(spec, parent)
    if isinstance(spec, Choice):
        return ChoiceEditor(spec, parent)
    if isinstance(spec, Str):
        return TextEditor(spec, parent)
    return ReadOnlyEditor(spec, parent)
