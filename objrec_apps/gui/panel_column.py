"""The column of parameter panels, one per module in pipeline order, kept in step with the pipeline."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QFormLayout, QLabel, QLineEdit, QVBoxLayout, QWidget

from objrec_core import Change, Parametrizable, RecognitionSystem, StageResults

from .panels import create_panel


class _SystemBinding:
    """The system's observer: hands each notification's changes to the column in the GUI thread."""

    def __init__(self, column: PanelColumn) -> None:
        self.column: PanelColumn | None = column

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        column = self.column
        if column is not None:
            column.system_changed.emit(tuple(changes))


class PanelColumn(QWidget):
    """Panels for every module of ``system``, plus the object name that detections carry.

    Panels of modules that stay in the pipeline are kept (with their observer binding) when modules are
    added, removed or moved; only new modules get new panels. ``pipeline_changed`` follows a pipeline change
    once the panels match it.
    """

    error = Signal(str)
    pipeline_changed = Signal()
    system_changed = Signal(object)

    def __init__(self, system: RecognitionSystem, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.system = system
        self._panels: list[tuple[Parametrizable, QWidget]] = []
        layout = QVBoxLayout(self)
        header = QFormLayout()
        self.object_name = QLineEdit(system.object_name)
        self.object_name.setToolTip("The name every detected object carries in objrec-detect's output")
        self.object_name.editingFinished.connect(self._object_name_edited)
        header.addRow(QLabel("Object name"), self.object_name)
        layout.addLayout(header)
        self.panel_layout = QVBoxLayout()
        layout.addLayout(self.panel_layout)
        self.empty_label = QLabel("The pipeline is empty: add filters and a detector from the Pipeline menu.")
        self.empty_label.setWordWrap(True)
        layout.addWidget(self.empty_label)
        layout.addStretch(1)
        self.system_changed.connect(self._system_changed)
        self._binding = _SystemBinding(self)
        system.add_observer(self._binding)
        self.rebuild()

    @property
    def panels(self) -> list[QWidget]:
        return [panel for _, panel in self._panels]

    def panel(self, module_id: str) -> QWidget:
        for module, panel in self._panels:
            if module.id == module_id:
                return panel
        raise KeyError(f"no panel for module {module_id!r}")

    def show_results(self, results: StageResults) -> None:
        """Hand the results of the frame now on screen to every panel that shows per-frame information
        (one with a ``show_results(results)`` method): what a detector found or why not is read from
        there, never back from the detector."""
        for _, panel in self._panels:
            show = getattr(panel, "show_results", None)
            if show is not None:
                show(results)

    def _system_changed(self, changes: Sequence[Change]) -> None:
        names = {c.name for c in changes}
        if "object_name" in names:
            self.object_name.setText(self.system.object_name)
        if "pipeline" in names:
            self.rebuild()
            self.pipeline_changed.emit()

    def rebuild(self) -> None:
        """Match the panels to the pipeline: keep, add, drop and reorder."""
        self.object_name.setText(self.system.object_name)
        modules = list(self.system.modules)
        if [m for m, _ in self._panels] == modules:
            return
        kept = {id(m): p for m, p in self._panels if any(m is n for n in modules)}
        for module, panel in self._panels:
            if id(module) not in kept:
                self._drop(panel)
        self._panels = []
        for module in modules:
            panel = kept.get(id(module))
            if panel is None:
                panel = create_panel(module)
                error = getattr(panel, "error", None)
                if error is not None:
                    error.connect(self.error)
            self.panel_layout.removeWidget(panel)
            self.panel_layout.addWidget(panel)
            self._panels.append((module, panel))
        self.empty_label.setVisible(not modules)

    def _drop(self, panel: QWidget) -> None:
        detach = getattr(panel, "detach", None)
        if detach is not None:
            detach()
        self.panel_layout.removeWidget(panel)
        panel.hide()
        panel.deleteLater()

    def _object_name_edited(self) -> None:
        name = self.object_name.text().strip()
        if name and name != self.system.object_name:
            self.system.object_name = name

    def detach(self) -> None:
        self._binding.column = None
        self.system.remove_observer(self._binding)
        for _, panel in self._panels:
            detach = getattr(panel, "detach", None)
            if detach is not None:
                detach()
