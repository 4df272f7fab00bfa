"""``Colour``: a colour parameter, kept as ``#rrggbb`` text so a parameter file holds it as written."""

from __future__ import annotations

import re
from typing import Any

from declare import Parameter

_HEX = re.compile(r"^#[0-9a-f]{6}$")
#: Names text may use for a colour (a source option, a command line); files hold the ``#rrggbb`` form.
NAMED = {"black": "#000000", "white": "#ffffff", "red": "#ff0000", "green": "#00ff00", "blue": "#0000ff"}


def rgb(colour: str) -> tuple[int, int, int]:
    """``#ff8000`` as ``(255, 128, 0)``."""
    return int(colour[1:3], 16), int(colour[3:5], 16), int(colour[5:7], 16)


class Colour(Parameter):
    """An RGB colour, ``#rrggbb`` in lower case. Text may also name one (``red``) or leave out the ``#``."""

    type_name = "colour"

    def validate_value(self, value: Any, module: str) -> str:
        if not isinstance(value, str):
            raise self._fail(module, value, f"expected a colour #rrggbb, got {type(value).__name__}")
        if not _HEX.match(value):
            raise self._fail(module, value, "expected a colour #rrggbb in lower case (e.g. #ff8000)")
        return str(value)

    def describe_value(self) -> str:
        return "colour #rrggbb"

    def from_text(self, text: str) -> str:
        lowered = text.lower()
        if lowered in NAMED:
            return NAMED[lowered]
        return lowered if lowered.startswith("#") else "#" + lowered

    def invalid_examples(self) -> list[tuple[str, Any]]:
        return [("a colour without #", "ff8000"), ("three digits", "#f80"), ("upper case", "#FF8000"),
                ("not hex digits", "#gg0000"), ("a number for a colour", 0xFF8000), ("a list of levels", [255, 128, 0]),
                *super().invalid_examples()]

    def invalid_texts(self) -> list[tuple[str, str]]:
        return [("a name it does not know", "mauve"), ("too few digits", "#12345"), ("not hex digits", "gg0000")]

    def boundary_values(self) -> list[Any]:
        return ["#000000", "#ffffff", *super().boundary_values()]

    def alternatives(self, default: Any) -> list[Any]:
        return [c for c in ("#808080", "#000000", "#ffffff") if c != default] + super().alternatives(default)
