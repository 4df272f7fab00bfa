"""The two errors of strictio: an input that cannot be read as asked, an output that cannot be written.

Both show names and values from files escaped (:func:`escape_controls`): a key holding a newline or a terminal
escape code can neither split the one error line nor fake output. The attributes keep the raw text, so a
caller can still compare ``exc.path`` with a path it holds.
"""

from __future__ import annotations

import os
import unicodedata

_NAMED = {0x09: "\\t", 0x0A: "\\n", 0x0D: "\\r"}


def _escape(char: str) -> str:
    code = ord(char)
    if code in _NAMED:
        return _NAMED[code]
    return f"\\x{code:02x}" if code <= 0xFF else f"\\u{code:04x}" if code <= 0xFFFF else f"\\U{code:08x}"


#: What a terminal acts on instead of printing: C0 and C1 controls, DEL, line and paragraph separators and
#: the bidirectional overrides that reorder what follows them (category Cc, Zl, Zp and the Cf marks below).
_BIDI = (*range(0x200E, 0x2010), *range(0x202A, 0x202F), *range(0x2066, 0x206A), 0x061C, 0xFEFF)
_CONTROL = {code: _escape(chr(code)) for code in (*range(0x20), *range(0x7F, 0xA0), 0x2028, 0x2029, *_BIDI)}


def escape_controls(text: object) -> str:
    """``text`` with every character a terminal would act on shown as an escape (``\\n``, ``\\x1b``, ``\\u202e``).

    Backslashes stay as they are, so escaping twice changes nothing and Windows paths stay readable.
    """
    shown = str(text).translate(_CONTROL)
    if shown.isprintable():
        return shown
    # rarer format and unassigned characters outside the table (a surrogate from a mis-decoded name)
    return "".join(_escape(c) if unicodedata.category(c) in ("Cc", "Cs", "Zl", "Zp") else c for c in shown)


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
