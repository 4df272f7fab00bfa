"""How untrusted text is shown: the one place that decides what a terminal may receive of it.

A name from a file, a source typed on the command line, a value from YAML: any of them may hold a newline
(which splits the one error line a command promises), a terminal escape code (which fakes output or colours)
or a bidirectional override such as U+202E (which makes ``zz\\u202eabc:1`` print as ``zz1:cba``). Every
message path shows such text through :func:`escape_controls`, or through :func:`printable` (also shortened) and
:func:`short_repr` (a value's repr, never the whole of a huge one), which use it.
"""

from __future__ import annotations

import reprlib
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

#: How much of a name or value a message quotes by default.
SHOWN_LENGTH = 60

_short = reprlib.Repr()
_short.maxstring = SHOWN_LENGTH
_short.maxother = SHOWN_LENGTH
_short.maxlist = _short.maxtuple = _short.maxdict = 4
_short.maxlevel = 2


def escape_controls(text: object) -> str:
    """``text`` with every character a terminal would act on shown as an escape (``\\n``, ``\\x1b``, ``\\u202e``).

    Backslashes stay as they are, so escaping twice changes nothing and Windows paths stay readable.
    """
    shown = str(text).translate(_CONTROL)
    if shown.isprintable():
        return shown
    # rarer format and unassigned characters outside the table (a surrogate from a mis-decoded name)
    return "".join(_escape(c) if unicodedata.category(c) in ("Cc", "Cs", "Zl", "Zp") else c for c in shown)


def printable(text: object, limit: int = SHOWN_LENGTH) -> str:
    """Text from a file or a user as a message shows it: escaped (:func:`escape_controls`), never longer than
    ``limit`` (a cut one ends in ``...``)."""
    shown = escape_controls(text)
    return shown if len(shown) <= limit else shown[: limit - 3] + "..."


def short_repr(value: object) -> str:
    """A value as error messages show it: its repr, escaped, never the whole of a huge or deeply nested one."""
    return escape_controls(_short.repr(value))
