"""Never lose work: whether the window holds unsaved changes, the question asked before they would be lost,
the values each module was opened with (the first "Restore" choice), and the description saved in the file.

The description follows the values unless the user wrote one: a description that is empty, or that is
exactly what ``describe`` says of the values it was opened with, is regenerated from the modules on
every save (so it never says "open" after the operation became "dilate"); any other text is the user's own
and is saved as it is.
"""

from __future__ import annotations

import contextlib
import weakref
from collections.abc import Callable
from enum import Enum
from typing import Any

import shiboken6
from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QTextOption, QUndoStack
from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QLabel,
    QMessageBox,
    QPlainTextEdit,
    QVBoxLayout,
    QWidget,
)

from objrec_core import Detector, Parametrizable, RecognitionSystem

#: The values each module had when its file (or starting system) was opened; weak, so removed modules go.
_opened: weakref.WeakKeyDictionary[Parametrizable, dict[str, Any]] = weakref.WeakKeyDictionary()


def remember_opened_values(system: RecognitionSystem) -> None:
    """The values now in force are those the file (or starting system) was opened with."""
    for module in system.modules:
        _opened[module] = module.get_parameters()


def opened_values(module: Parametrizable) -> dict[str, Any] | None:
    """The values ``module`` was opened with; None for a module added since."""
    return _opened.get(module)


def _value(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def describe(system: RecognitionSystem) -> str:
    """One line saying what the pipeline does with its current values (relevant parameters only)."""
    parts = []
    for module in system.modules:
        values = module.get_parameters()
        shown = ", ".join(f"{name} {_value(values[name])}" for name in module.relevant_parameters())
        what = f"{module.type_name} {module.id}"
        if isinstance(module, Detector):
            what += f" finds {system.object_name}"
        parts.append(what + (f" ({shown})" if shown else ""))
    return ("; ".join(parts) + ".") if parts else ""


class Answer(Enum):
    SAVE = "save"
    DISCARD = "discard"
    CANCEL = "cancel"


class DescriptionDialog(QDialog):
    """Edit > Description: the text wraps at the box's width (a one-line box hid all but the start of a
    long description) and every control has a mnemonic."""

    def __init__(self, text: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("description_dialog")
        self.setWindowTitle("Description")
        layout = QVBoxLayout(self)
        label = QLabel("&Description: what this parameter file finds (leave empty to have it follow the values)")
        label.setWordWrap(True)
        self.edit = QPlainTextEdit(text)
        self.edit.setLineWrapMode(QPlainTextEdit.LineWrapMode.WidgetWidth)
        self.edit.setWordWrapMode(QTextOption.WrapMode.WordWrap)
        self.edit.setTabChangesFocus(True)
        label.setBuddy(self.edit)
        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        buttons.button(QDialogButtonBox.StandardButton.Ok).setText("&OK")
        buttons.button(QDialogButtonBox.StandardButton.Cancel).setText("&Cancel")
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout.addWidget(label)
        layout.addWidget(self.edit, 1)
        layout.addWidget(buttons)
        self.resize(520, 240)

    def text(self) -> str:
        return self.edit.toPlainText()


class ChangeTracker(QObject):
    """The window's document state: modified or not (from the undo stack's clean state), the question
    before losing changes, the opened values and the description policy.

    ``save`` is called for the Save answer and says whether it saved; ``ask`` may be replaced (a test, an
    embedding app) and returns an Answer for a question text.
    """

    modifiedChanged = Signal(bool)  # noqa: N815 - Qt's signal naming

    def __init__(self, system: RecognitionSystem, stack: QUndoStack, window: QWidget,
                 save: Callable[[], bool]) -> None:
        super().__init__(window)
        self.system = system
        self.stack = stack
        self.window = window
        self.save = save
        self.ask: Callable[[str], Answer] = self.ask_with_dialog
        self.description_is_users = False
        self.stack.cleanChanged.connect(self._clean_changed)
        self.opened()

    def _clean_changed(self, clean: bool) -> None:
        # A stack with steps left emits cleanChanged from its own destructor (it clears itself): by then the
        # window is being torn down and asking anything of the stack raises (a traceback
        # after Quit, Discard). A stack that is going away has no state to report.
        if shiboken6.isValid(self.stack) and shiboken6.isValid(self):
            self.modifiedChanged.emit(not clean)

    def detach(self) -> None:
        """The window closes: the stack's last signals (while it is destroyed) reach no one."""
        with contextlib.suppress(RuntimeError, TypeError):  # already disconnected, or the stack already gone
            self.stack.cleanChanged.disconnect(self._clean_changed)

    @property
    def modified(self) -> bool:
        """Whether the parameters differ from the file's: a step between the clean state and now that is not
        a label edit (those are the label mode's to ask about: ``labels_only`` steps, label_model.py)."""
        if self.stack.isClean():
            return False
        clean, index = self.stack.cleanIndex(), self.stack.index()
        if clean < 0:
            return True
        low, high = sorted((clean, index))
        return any(not getattr(self.stack.command(i), "labels_only", False) for i in range(low, high))

    def opened(self) -> None:
        """A file or starting system was opened: remember its values; its description is the user's own
        unless it is what ``describe`` says of these values."""
        remember_opened_values(self.system)
        text = self.system.description
        self.description_is_users = bool(text) and text != describe(self.system)
        self._opened_description = text
        self._opened_modules = list(self.system.modules)

    def tuned(self) -> bool:
        """Whether the pipeline or any value differs from what was opened."""
        modules = list(self.system.modules)
        if len(modules) != len(self._opened_modules) or any(a is not b for a, b in zip(modules, self._opened_modules,
                                                                                       strict=True)):
            return True
        return any(opened_values(module) != module.get_parameters() for module in modules)

    def before_save(self, shipped: bool = False) -> None:
        """Bring a description that follows the values up to date (no undo step: the save makes it). A
        system started from a shipped file (``shipped``) and tuned no longer is what the shipped description
        says: unless the user wrote their own, the saved one is made from the values."""
        if not self.system.modules:
            return
        stale = shipped and self.system.description == self._opened_description and self.tuned()
        if not self.description_is_users or stale:
            self.description_is_users = False
            self.system.set_identity(self.system.object_name, describe(self.system), notify=False)

    def set_description(self, text: str) -> None:
        """The user's own description; an empty one follows the values again."""
        self.description_is_users = bool(text.strip())
        self.system.description = text.strip() if text.strip() else describe(self.system)

    def edit_description(self) -> DescriptionDialog:
        """Ask for the description in a dialog (window-modal, not blocking); the dialog is returned."""
        dialog = DescriptionDialog(self.system.description if self.description_is_users else "", self.window)
        dialog.accepted.connect(lambda: self.set_description(dialog.text()))
        dialog.finished.connect(lambda _result: dialog.deleteLater())
        self.description_dialog = dialog
        dialog.open()
        return dialog

    def forget(self) -> None:
        """Treat the changes as saved (an embedding app or a test closing without asking)."""
        self.stack.setClean()

    # -- the question -------------------------------------------------------------------------------------
    def ask_with_dialog(self, question: str) -> Answer:
        box = QMessageBox(QMessageBox.Icon.Warning, "Unsaved changes", question,
                          QMessageBox.StandardButton.Save | QMessageBox.StandardButton.Discard
                          | QMessageBox.StandardButton.Cancel, self.window)
        box.setObjectName("unsaved_changes")
        box.setDefaultButton(QMessageBox.StandardButton.Save)
        for button, text in ((QMessageBox.StandardButton.Save, "&Save"), (QMessageBox.StandardButton.Discard,
                                                                         "&Discard"),
                             (QMessageBox.StandardButton.Cancel, "&Cancel")):
            box.button(button).setText(text)  # mnemonics: Alt+S, Alt+D, Alt+C
        answer = box.exec()
        if answer == QMessageBox.StandardButton.Save:
            return Answer.SAVE
        if answer == QMessageBox.StandardButton.Discard:
            return Answer.DISCARD
        return Answer.CANCEL

    def may_lose_changes(self, what: str) -> bool:
        """Before ``what`` ("quitting", "opening another file") would lose unsaved changes: True to go on
        (nothing unsaved, saved, or discarded), False to stop (cancelled, or the save failed)."""
        if not self.modified:
            return True
        answer = self.ask(f"The parameters have unsaved changes. Save them before {what}?")
        if answer is Answer.SAVE:
            return bool(self.save())
        return answer is Answer.DISCARD
