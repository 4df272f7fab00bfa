"""File > Open Recent: the parameter files last opened or saved, kept in the window's QSettings,
newest first. A file that no longer exists is left out of the menu rather than offered to fail."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QMenu, QWidget

#: The settings key and how many files the menu offers.
KEY = "files/recent"
KEEP = 8


class RecentFiles:
    """The list in ``settings`` and the menu that offers it; ``open_path(path)`` opens a chosen one."""

    def __init__(self, settings: QSettings, open_path: Callable[[str], object], parent: QWidget) -> None:
        self.settings = settings
        self.open_path = open_path
        self.menu = QMenu("Open &Recent", parent)
        self.menu.setObjectName("recent_files")
        self.menu.aboutToShow.connect(self.rebuild)
        self.rebuild()

    def paths(self) -> list[str]:
        """The files kept, newest first."""
        value = self.settings.value(KEY, [])
        items = [value] if isinstance(value, str) else list(value or [])
        return [str(item) for item in items if str(item)]

    def add(self, path: str) -> None:
        """``path`` was opened or saved: first in the list, once."""
        full = str(Path(path).resolve())
        kept = [full, *(p for p in self.paths() if p != full)][:KEEP]
        self.settings.setValue(KEY, kept)
        self.settings.sync()
        self.rebuild()

    def rebuild(self) -> None:
        self.menu.clear()
        shown = [path for path in self.paths() if Path(path).is_file()]
        for number, path in enumerate(shown, 1):
            label = f"&{number} {Path(path).name}" if number < 10 else Path(path).name
            action = self.menu.addAction(label)
            action.setToolTip(path)
            action.setStatusTip(path)
            action.triggered.connect(lambda _=False, p=path: self.open_path(p))
        if not shown:
            self.menu.addAction("(no recent files)").setEnabled(False)
        else:
            self.menu.addSeparator()
            self.menu.addAction("&Clear the list", self.clear)
        self.menu.setEnabled(True)

    def clear(self) -> None:
        self.settings.setValue(KEY, [])
        self.rebuild()
