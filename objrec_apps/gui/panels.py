"""Parameter panels bound to their module in a Document-View design: the widget calls the module's setter,
the module notifies its observers with the changes, the panel shows the changed values from the module's
getters. A change made anywhere else (code, File>Open, another panel) therefore shows at once.

A module type that needs more than the generated widgets registers its own panel: ``register_panel`` in
code, or an entry point in the ``objrec.gui_panels`` group (name = module type, value = a callable taking
the module and returning a QWidget) so a plug-in package needs no change to objrec.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)

from declare.registry import PluginError, Registry
from objrec_core import Change, ParameterError, Parametrizable

from .changes import opened_values
from .param_widgets import ParameterEditor, editor_for
from .undo import gestures

log = logging.getLogger(__name__)

PANEL_GROUP = "objrec.gui_panels"
#: The narrowest a slider's field (slider and spin box) gets beside its name; narrower, the name goes above
#: it. Beside a long name (homography_max_iterations) in a 360 px dock the slider was a few pixels long.
SLIDER_FIELD_MIN_WIDTH = 200
PanelFactory = Callable[[Parametrizable], QWidget]


def _valid_factory(name: str, obj: Any) -> PanelFactory:
    if not callable(obj):
        raise TypeError(f"{obj!r} is not a callable that makes a panel for a {name} module")
    return obj


#: Panels that replace the generated one, by module type: the same registry rules as every plug-in group
#: (entry-point name as key, duplicates refused naming both distributions, lazy loading).
PANELS: Registry[PanelFactory] = Registry(PANEL_GROUP, "parameter panel", validate=_valid_factory)


def register_panel(type_name: str, factory: PanelFactory) -> None:
    """Use ``factory(module)`` instead of the generated panel for modules of this type (or subclasses)."""
    PANELS.register(factory, type_name)


def unregister_panel(type_name: str) -> None:
    PANELS.unregister(type_name)


def panel_factory(module: Parametrizable) -> PanelFactory:
    """The registered factory for the module's type or nearest base class; else the generated panel."""
    names = [module.type_name] + [k.__name__ for k in type(module).__mro__]
    for name in names:
        if name not in PANELS:
            continue
        try:
            return PANELS.get(name)
        except PluginError as exc:  # a broken plug-in panel must not cost the user the generated one
            log.warning("%s; using the generated panel", exc)
            break
    return ParameterPanel


def create_panel(module: Parametrizable) -> QWidget:
    return panel_factory(module)(module)


class _Binding:
    """The module's observer: forwards each notification's changes, from whatever thread, to the panel's
    signal (queued when a worker thread made the change)."""

    def __init__(self, panel: ParameterPanel) -> None:
        self.panel: ParameterPanel | None = panel

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        panel = self.panel
        if panel is not None:
            panel.module_changed.emit(tuple(changes))


class ParameterPanel(QGroupBox):
    """The generated panel: one editor per declared parameter, and two Restore buttons: the values the
    file (or starting system) was opened with, and the declared defaults.

    Titled with the module's id (and its type where the two differ). Only the parameters that matter with
    the current values are shown (``spec.is_relevant``), re-evaluated after every change; a change updates
    only the editors of the parameters it names. ``error`` carries the message of a value the module
    refused, for the status bar; the editor then snaps back to the module's value.
    """

    error = Signal(str)
    module_changed = Signal(object)

    def __init__(self, module: Parametrizable, parent: QWidget | None = None) -> None:
        title = module.id if module.id == module.type_name else f"{module.id}  ({module.type_name})"
        super().__init__(title, parent)
        self.module = module
        self.setObjectName(f"panel:{module.id}")
        self.setToolTip((type(module).__doc__ or module.type_name).strip().split("\n\n")[0])
        self.editors: dict[str, ParameterEditor] = {}
        self._specs = {spec.name: spec for spec in module.parameter_specs()}
        self._shown: set[str] = set(self._specs)
        layout = QVBoxLayout(self)
        self.form = QFormLayout()
        self.form.setFieldGrowthPolicy(QFormLayout.FieldGrowthPolicy.AllNonFixedFieldsGrow)
        # A row too narrow for its name and field puts the name above: the dock scrolls down, never sideways.
        self.form.setRowWrapPolicy(QFormLayout.RowWrapPolicy.WrapLongRows)
        layout.addLayout(self.form)
        for spec in self._specs.values():
            editor = editor_for(spec, self)
            editor.edited.connect(self._edited)
            sliders = editor.findChildren(QSlider)
            for slider in sliders:  # a drag is one undo step (changes merge while held)
                slider.sliderPressed.connect(gestures.begin)
                slider.sliderReleased.connect(gestures.end)
            if sliders:
                editor.setMinimumWidth(max(SLIDER_FIELD_MIN_WIDTH, editor.minimumSizeHint().width()))
            label = QLabel(spec.name)
            label.setToolTip(editor.toolTip())
            self.form.addRow(label, editor)
            self.editors[spec.name] = editor
        if not self.editors:
            layout.addWidget(QLabel("no parameters"))
        buttons = QHBoxLayout()
        buttons.addStretch(1)
        self.restore_opened_button = QPushButton("Restore opened values")
        self.restore_opened_button.setToolTip("Set every parameter of this module back to the values the file "
                                              "(or starting system) was opened with")
        self.restore_opened_button.clicked.connect(self.restore_opened)
        self.restore_opened_button.setEnabled(bool(self.editors))
        buttons.addWidget(self.restore_opened_button)
        self.restore_button = QPushButton("Restore defaults")
        self.restore_button.setToolTip("Set every parameter of this module back to its declared default (these "
                                       "may pass everything: a filter's defaults keep the whole frame)")
        self.restore_button.clicked.connect(self.restore_defaults)
        self.restore_button.setEnabled(bool(self.editors))
        buttons.addWidget(self.restore_button)
        layout.addLayout(buttons)
        self.module_changed.connect(self.apply_changes, Qt.ConnectionType.AutoConnection)
        self._binding = _Binding(self)
        module.add_observer(self._binding)
        self.redraw()

    @property
    def shown_parameters(self) -> list[str]:
        """The parameters whose editors are shown (the relevant ones), in declaration order."""
        return [name for name in self.editors if name in self._shown]

    def redraw(self) -> None:
        """Show every current value and which parameters matter (the View half of the binding)."""
        values = self.module.get_parameters()
        for name, editor in self.editors.items():
            editor.show_value(values[name])
        self._show_relevant(values)

    def apply_changes(self, changes: Sequence[Change]) -> None:
        """Show what changed: the editors of the parameters named, then which parameters matter now."""
        names = [c.name for c in changes if c.name in self.editors]
        if not names:
            return
        values = self.module.get_parameters()  # the value in force now: a later change may have overtaken
        for name in dict.fromkeys(names):
            self.editors[name].show_value(values[name])
        self._show_relevant(values)

    def _show_relevant(self, values: dict[str, Any]) -> None:
        shown = {name for name, spec in self._specs.items() if spec.is_relevant(values)}
        if shown == self._shown:
            return
        for name, editor in self.editors.items():
            if (name in shown) != (name in self._shown):
                self.form.setRowVisible(editor, name in shown)
        self._shown = shown

    def _edited(self, name: str, value: Any) -> None:
        try:
            self.module.set_parameters(**{name: value})
        except (ParameterError, ValueError) as exc:
            self.error.emit(str(exc))
            self.editors[name].show_value(self.module.get_parameters()[name])

    def restore_defaults(self) -> None:
        """The declared defaults (which may pass everything: the whole frame becomes one object)."""
        self._restore(self.module.default_values())

    def restore_opened(self) -> None:
        """The values the file or starting system was opened with; a module added since was added with its
        defaults, so it gets those."""
        self._restore(opened_values(self.module) or self.module.default_values())

    def _restore(self, values: dict[str, Any]) -> None:
        """One set_parameters call: one notification, one undo step."""
        try:
            self.module.set_parameters(**values)
        except (ParameterError, ValueError) as exc:
            self.error.emit(str(exc))

    def detach(self) -> None:
        """Stop observing the module (before the panel goes away)."""
        self._binding.panel = None
        self.module.remove_observer(self._binding)
