"""The Qt editor of ``Colour``: a swatch and a line of text (``#rrggbb``, a name, or hex without ``#``)."""

from __future__ import annotations

from typing import Any

from PySide6.QtCore import QSignalBlocker
from PySide6.QtWidgets import QLabel, QLineEdit, QWidget

from declare import ParameterError
from objrec_apps.gui.param_widgets import ParameterEditor, register_editor, unregister_editor

from .colour import Colour


class ColourEditor(ParameterEditor):
    """Typed text goes through the declaration's ``parse_text``, so ``red`` or ``FF8000`` become the
    canonical ``#rrggbb``; text it refuses is sent as typed, for the module to refuse with its message."""

    def __init__(self, spec: Colour, parent: QWidget | None = None) -> None:
        super().__init__(spec, parent)
        self.swatch = QLabel()
        self.swatch.setFixedSize(24, 16)
        self.line = QLineEdit()
        self.line.editingFinished.connect(self._typed)
        self.layout().addWidget(self.swatch)
        self.layout().addWidget(self.line, 1)

    def show_value(self, value: Any) -> None:
        with QSignalBlocker(self.line):
            self.line.setText(str(value))
        self.swatch.setStyleSheet(f"background-color: {value}")

    def tooltip_details(self) -> list[str]:
        return ["type #rrggbb, a name such as red, or hex digits alone"]

    def _typed(self) -> None:
        text = self.line.text()
        try:
            self._emit(self.spec.parse_text(text, "editor"))
        except ParameterError:
            self._emit(text)


def register() -> None:
    """Give every ``Colour`` parameter this editor (a plug-in calls it where it sets up its GUI part)."""
    register_editor(Colour, ColourEditor)


def unregister() -> None:
    unregister_editor(Colour)
