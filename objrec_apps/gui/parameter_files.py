"""File>Open, Save and Save As for the window: ParameterStorage behind dialogs, with status messages.

Open keeps the modules (and so their panels) when the file holds the pipeline already on screen, and
replaces the whole pipeline otherwise; either way nothing changes unless the whole file is valid, and the
message shown is the file's own ``ParameterFileError`` (file, key path, problem), never a traceback.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from PySide6.QtCore import QObject, QSettings, Signal
from PySide6.QtWidgets import QFileDialog, QWidget

from objrec_core import Opened, ParameterFileError, ParameterStorage, RecognitionSystem

FILE_FILTER = "Parameter files (*.yaml *.yml);;All files (*)"
LAST_FOLDER_KEY = "files/last_folder"


class ParameterFiles(QObject):
    """The current file's path and the three File actions. ``exclusive`` is entered around every load and
    save, so the processing thread never sees half a loaded file.

    ``origin`` names the shipped file a system was started from (``hsv_demo.yaml``): such a system is
    untitled, so Save asks where (suggesting that name) instead of overwriting the shipped file.
    """

    message = Signal(str)
    pathChanged = Signal(str)  # noqa: N815 - Qt's signal naming
    opened = Signal(str)
    saved = Signal(str)

    def __init__(
        self,
        system: RecognitionSystem,
        settings: QSettings,
        parent: QWidget,
        exclusive: Callable[[], contextlib.AbstractContextManager[Any]] = contextlib.nullcontext,
    ) -> None:
        super().__init__(parent)
        self.system = system
        self.storage = ParameterStorage(system)
        self.settings = settings
        self.window = parent
        self.exclusive = exclusive
        self.path: Path | None = None
        self.origin: str | None = None
        #: Asked before a file replaces what is on screen (``guard("opening another file")``): False stops.
        #: The window asks about unsaved changes here.
        self.guard: Callable[[str], bool] = lambda _what: True
        #: Called before every write (the window brings a description that follows the values up to date).
        self.before_write: Callable[[], None] = lambda: None

    # -- the folder dialogs start in ------------------------------------------------------------------------
    def last_folder(self) -> str:
        folder = str(self.settings.value(LAST_FOLDER_KEY, "") or "")
        return folder if folder and Path(folder).is_dir() else str(Path.cwd())

    def remember_folder(self, path: str | Path) -> None:
        path = Path(path)
        self.settings.setValue(LAST_FOLDER_KEY, str(path if path.is_dir() else path.parent))

    def set_path(self, path: Path | None) -> None:
        self.path = path
        if path is not None:
            self.origin = None
        self.pathChanged.emit(str(path) if path else "")

    def set_origin(self, name: str) -> None:
        """The system on screen was started from the shipped file ``name``: untitled until saved."""
        self.path = None
        self.origin = name
        self.pathChanged.emit("")

    # -- the actions --------------------------------------------------------------------------------------
    def open(self, path: str | Path | None = None) -> bool:
        """Ask for a file (unless given) and load it; False if cancelled or refused. Unsaved changes are
        asked about first (``guard``)."""
        if not self.guard("opening another file"):
            return False
        if path is None:
            chosen, _ = QFileDialog.getOpenFileName(self.window, "Open a parameter file", self.last_folder(),
                                                    FILE_FILTER)
            if not chosen:
                return False
            path = chosen
        return self.load(Path(path))

    def load(self, path: Path) -> bool:
        try:
            with self.exclusive():
                opened = self.storage.open(path)
        except ParameterFileError as exc:
            self.message.emit(f"Not opened: {exc}")
            return False
        self.remember_folder(path)
        self.set_path(path)
        modules = ", ".join(m.id for m in self.system.modules)
        how = "values loaded into the modules on screen" if opened is Opened.KEPT else "a new pipeline"
        self.message.emit(f"Opened {path} ({self.system.kind}: {modules}; {how})")
        self.opened.emit(str(path))
        return True

    def save(self) -> bool:
        """Overwrite the current file; without one, Save As."""
        if self.path is None:
            return self.save_as()
        return self.write(self.path)

    def save_as(self, path: str | Path | None = None) -> bool:
        """Always asks where (unless given); adds .yaml when the name has no suffix."""
        if path is None:
            start = str(self.path) if self.path else str(Path(self.last_folder()) / (self.origin or "objrec.yaml"))
            chosen, _ = QFileDialog.getSaveFileName(self.window, "Save the parameter file as", start, FILE_FILTER)
            if not chosen:
                return False
            path = chosen
        path = Path(path)
        if not path.suffix:
            path = path.with_suffix(".yaml")
        return self.write(path)

    def write(self, path: Path) -> bool:
        try:
            with self.exclusive():
                self.before_write()
                self.storage.save_parameters(path)
        except ParameterFileError as exc:
            self.message.emit(f"Not saved: {exc}")
            return False
        self.remember_folder(path)
        self.set_path(path)
        self.message.emit(f"Saved {path}")
        self.saved.emit(str(path))
        return True
