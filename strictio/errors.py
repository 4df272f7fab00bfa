"""The two errors of strictio: an input that cannot be read as asked, an output that cannot be written.

Both show names and values from files escaped (:func:`strictio.shown.escape_controls`): a key holding a newline
or a terminal escape code can neither split the one error line nor fake output. The attributes keep the raw text, so a
caller can still compare ``exc.path`` with a path it holds.
"""

from __future__ import annotations

import os

from .shown import escape_controls

__all__ = ["InputError", "OutputError", "escape_controls"]


def _rebuilt(cls: type[BaseException], args: tuple[object, ...], state: dict[str, object]) -> BaseException:
    """An error unpickled in another process (a batch worker's), whatever its class's own signature."""
    error = cls.__new__(cls, *args)
    error.args = args
    error.__dict__.update(state)
    return error


class InputError(ValueError):
    """An input file refused or unreadable: names the file, where in it (a key path or line) and why."""

    def __init__(self, path: str | os.PathLike[str], message: str, where: str = "") -> None:
        self.path = str(path)
        self.where = where
        self.message = message
        place = f"{self.path}: {where}" if where else self.path
        super().__init__(escape_controls(f"{place}: {message}"))

    def __reduce__(self) -> tuple[object, ...]:
        return _rebuilt, (type(self), self.args, self.__dict__)


class OutputError(OSError):
    """An output that cannot be written; the old file, if any, is untouched."""

    def __init__(self, path: str | os.PathLike[str], message: str) -> None:
        self.path = str(path)
        self.message = message
        super().__init__(escape_controls(f"{self.path}: {message}"))

    def __str__(self) -> str:
        return escape_controls(f"{self.path}: {self.message}")

    def __reduce__(self) -> tuple[object, ...]:
        return _rebuilt, (type(self), self.args, self.__dict__)
