"""Which detector a rectangle drawn on the views is for.

A pipeline may hold two feature detectors, each to learn a target of its own: a selection goes to ONE
detector, so it is one change and one undo step. The detector is the one whose panel the user last worked
in (one of its controls used: it took the keyboard focus), when it takes selections; else the only detector that takes
selections; else the user chooses (``ask``). Detectors that ignore selections are never asked about.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

from PySide6.QtCore import QObject
from PySide6.QtWidgets import QApplication, QWidget

from objrec_core import RecognitionSystem, Rect, SelectionRefused, SelectionResult, StageResults

from .message_area import takes_selections

#: ``ask(title, labels)``: one of the labels, chosen by the user, or None when cancelled.
Ask = Callable[[str, list[str]], "str | None"]


def selecting_detectors(system: RecognitionSystem) -> list[Any]:
    """The pipeline's detectors that do something with a selection, in pipeline order."""
    return [detector for detector in system.detectors if takes_selections(detector)]


def select_in(detector: Any, rect: Rect, results: StageResults) -> SelectionResult:
    """Give ``rect`` to ``detector`` with the input it saw in ``results`` (the frame the user drew on):
    the outcome in the director's form (accepted, or refused with the reason)."""
    outcome = SelectionResult()
    seen = next((s.output for s in results.stages if s.role == "detector" and s.id == detector.id), None)
    if seen is None:
        outcome.refused[detector.id] = "it was not in the pipeline when this frame was processed"
        return outcome
    try:
        detector.process_area_selection(rect, seen)
    except SelectionRefused as exc:
        outcome.refused[detector.id] = str(exc)
    else:
        outcome.accepted.append(detector.id)
    return outcome


class SelectionTarget(QObject):
    """Remembers the detector panel the user last worked in (inside ``column``) and chooses the target of a
    selection from it."""

    def __init__(self, system: RecognitionSystem, column: QWidget, ask: Ask, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.system = system
        self.column = column
        self.ask = ask
        #: The id of the module whose panel was last clicked or focused (None before the first).
        self.last_panel: str | None = None
        # Every control of a panel (slider, spin box, list, button) takes the focus when used: following the
        # focus finds the panel last worked in without filtering every event of the application.
        app = QApplication.instance()
        if isinstance(app, QApplication):
            app.focusChanged.connect(self._focus_changed)

    def detach(self) -> None:
        app = QApplication.instance()
        if isinstance(app, QApplication):
            with contextlib.suppress(RuntimeError, TypeError):
                app.focusChanged.disconnect(self._focus_changed)

    def _focus_changed(self, old: QWidget | None, new: QWidget | None) -> None:
        # From no focus at all: the window was activated and Qt gave the focus to a widget itself (its first,
        # or the one it had): not a panel the user chose.
        if old is not None and new is not None:
            self._touched(new)

    def _touched(self, widget: QWidget) -> None:
        """Note the module of the panel holding ``widget``, when it is inside the panel column."""
        module_id = None
        current: QWidget | None = widget
        while current is not None and current is not self.column:
            module = getattr(current, "module", None)
            if module_id is None and module is not None and hasattr(module, "id"):
                module_id = module.id
            current = current.parentWidget()
        if current is self.column and module_id is not None:
            self.last_panel = module_id

    def choose(self) -> list[Any] | None:
        """The detector(s) to give the next selection: one when any takes selections (the last panel's, the
        only one, or the one the user picks), every detector when none does (so the report says none took
        it); None when the user cancelled the choice."""
        candidates = selecting_detectors(self.system)
        if not candidates:
            return list(self.system.detectors)
        if len(candidates) == 1:
            return candidates
        by_id = {detector.id: detector for detector in candidates}
        if self.last_panel in by_id:
            return [by_id[self.last_panel]]
        chosen = self.ask("Which detector learns the selected target?", list(by_id))
        if chosen is None:
            return None
        self.last_panel = chosen
        return [by_id[chosen]]
