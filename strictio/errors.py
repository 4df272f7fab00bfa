"""The two errors of strictio: an input that cannot be read as asked, an output that cannot be written."""

from __future__ import annotations

import os


class InputError(ValueError):
    """An input file refused or unreadable: names the file, where in it (a key path or line) and why."""

    def __init__(self, path: str | os.PathLike[str], message: str, where: str = "") -> None:
        self.path = str(path)
        self.where = where
        self.message = message
        place = f"{self.path}: {where}" if where else self.path
        super().__init__(f"{place}: {message}")


class OutputError(OSError):
    """An output that cannot be written; the old file, if any, is untouched."""

    def __init__(self, path: str | os.PathLike[str], message: str) -> None:
        self.path = str(path)
        self.message = message
        super().__init__(f"{self.path}: {message}")

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"
