"""How untrusted text is shown: the one place that decides what a terminal may receive of it.

A name from a file, a source typed on the command line, a value from YAML: any of them may hold a newline
(which splits the one error line a command promises), a terminal escape code (which fakes output or colours)
or a bidirectional override such as U+202E (which makes ``zz\\u202eabc:1`` print as ``zz1:cba``). Every
message path shows such text through :func:`escape_controls`, or through :func:`printable` (also shortened) and
:func:`short_repr` (a value's repr, never the whole of a huge one), which use it.

Text leaves the process by two more ways: drawn into a picture by OpenCV, and written into a message or a file
that promises UTF-8 (a ROS string field, a JSON report, a file name). A lone surrogate (a name with non-UTF-8
bytes, read with ``surrogateescape``, or ``"\\udcff"`` in YAML) kills OpenCV's text drawing with a segmentation
fault and makes an encoder raise. :func:`drawable` is the one way text reaches ``cv2.putText`` and
``cv2.getTextSize``; :func:`valid_text` the one way it reaches a UTF-8 field. Both escape rather than drop, so
two different names stay different.
"""

from __future__ import annotations

import reprlib
import unicodedata
from functools import lru_cache

_NAMED = {0x09: "\\t", 0x0A: "\\n", 0x0D: "\\r"}


def _escape(char: str) -> str:
    code = ord(char)
    if code in _NAMED:
        return _NAMED[code]
    if 0xDC80 <= code <= 0xDCFF:  # a byte that is not UTF-8, kept by the file system's surrogateescape
        return f"\\x{code - 0xDC00:02x}"
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


#: How much of a text a picture shows at most (a label, a title): longer text is cut, ending in ``...``.
DRAWN_LENGTH = 200


def valid_text(text: object) -> str:
    """``text`` made encodable as UTF-8: each lone surrogate escaped (``\\xff`` for a byte of a name that is
    not UTF-8, ``\\ud800`` for any other), everything else unchanged. For a ROS string field, a JSON or YAML
    report, a file name made from a name."""
    shown = str(text)
    try:
        shown.encode("utf-8")
    except UnicodeEncodeError:
        return "".join(_escape(c) if 0xD800 <= ord(c) <= 0xDFFF else c for c in shown)
    return shown


def drawable(text: object) -> str:
    """``text`` as OpenCV's Hershey fonts can draw it: printable ASCII only, at most :data:`DRAWN_LENGTH`.

    Accented letters lose their accent (``Müsli`` -> ``Musli``); every other character outside printable ASCII
    (a control, a lone surrogate, a letter of another script) is shown as its escape (``\\u4e2d``), which
    OpenCV would otherwise draw as ``?``, or, for a lone surrogate, crash on.
    """
    return _drawable(str(text))


@lru_cache(maxsize=4096)  # the same labels are drawn on every frame
def _drawable(text: str) -> str:
    shown = []
    for char in text:
        if " " <= char <= "~":
            shown.append(char)
            continue
        base = "".join(c for c in unicodedata.normalize("NFKD", char) if not unicodedata.combining(c)) \
            if not 0xD800 <= ord(char) <= 0xDFFF else ""
        shown.append(base if base and all(" " <= c <= "~" for c in base) else _escape(char))
    drawn = "".join(shown)
    return drawn if len(drawn) <= DRAWN_LENGTH else drawn[: DRAWN_LENGTH - 3] + "..."
