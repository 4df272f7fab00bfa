"""Numbers on a command line, checked like declared parameters: finite, within a declared range, whole where
a count is meant; and one shape for every mistake: ``objrec-patrol: error: --odom-noise: nan is not a finite
number``, exit code 2, one line.

A number typed by a user is as untrusted as one read from a file: ``nan`` compares false with every bound and
slips through ``value > 0`` checks, ``inf`` makes a loop endless, ``1e400`` is infinite, ``-1`` as a seed is a
traceback deep in NumPy. Each option declares its range once, with a :class:`Number`; argparse calls it on the
text, and :class:`CommandLineParser` turns argparse's own messages into the same one-line shape.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NoReturn

from .limits import ALL_LIMITS
from .shown import printable

#: Exit code for a mistake in what the user asked for.
USAGE_ERROR = 2

#: How much of a user's number a message quotes.
_SHOWN = 40


def _bound(value: float) -> str:
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return f"{value:g}"


class NumberError(ValueError):
    """A text that is not a number the option allows; the message says why, without the option's name."""


@dataclass(frozen=True)
class Number:
    """One declared command-line number, used as an argparse ``type``.

    ``minimum``/``maximum`` are inclusive bounds (``None`` for an open side); ``above`` makes the minimum
    exclusive (a time step or a duration must be more than 0). ``whole`` asks for an integer; a text such as
    ``2.0`` is accepted as 2, ``2.5`` is not.
    """

    minimum: float | None = None
    maximum: float | None = None
    whole: bool = False
    above: bool = False

    def __post_init__(self) -> None:
        if self.minimum is not None and self.maximum is not None and self.minimum > self.maximum:
            raise ValueError(f"minimum {self.minimum} > maximum {self.maximum}")

    @property
    def __name__(self) -> str:  # argparse names a type by it in some messages
        return "whole number" if self.whole else "number"

    def describe(self) -> str:
        """The allowed values in words, for help texts."""
        low = "-inf" if self.minimum is None else _bound(self.minimum)
        high = "inf" if self.maximum is None else _bound(self.maximum)
        what = "a whole number" if self.whole else "a number"
        if self.above and self.minimum is not None:
            return f"{what} above {low}" + ("" if self.maximum is None else f", at most {high}")
        return f"{what} in {low}..{high}"

    def parse(self, text: str) -> float | int:
        """The number ``text`` stands for, or NumberError saying why it is not allowed."""
        stripped = text.strip()
        shown = printable(stripped, _SHOWN)
        if _INTEGER.fullmatch(stripped):
            value: float | int = int(stripped)
        elif _DECIMAL.fullmatch(stripped):
            value = float(stripped)  # digits beyond a float's range are infinite: refused by range below
        elif stripped.lower().lstrip("+-") in _NOT_FINITE:
            raise NumberError(f"{shown} is not a finite number")
        else:
            raise NumberError(f"'{printable(text, _SHOWN)}' is not {'a whole number' if self.whole else 'a number'}")
        if self.whole and isinstance(value, float) and math.isfinite(value) and not value.is_integer():
            raise NumberError(f"{shown} is not a whole number")
        self._check_range(value, shown)
        if not math.isfinite(value):
            raise NumberError(f"{shown} is not a finite number")
        return int(value) if self.whole else float(value)

    def _check_range(self, value: float, shown: str) -> None:
        low, high = self.minimum, self.maximum
        if low is not None and self.above and not value > low:
            raise NumberError(f"{shown} is not above {_bound(low)}")
        if low is not None and value < low:
            raise NumberError(f"{shown} is below the minimum {_bound(low)}")
        if high is not None and value > high:
            raise NumberError(f"{shown} is above the maximum {_bound(high)}")

    def __call__(self, text: str) -> float | int:
        try:
            return self.parse(text)
        except NumberError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None


#: The number syntax accepted: plain ASCII digits, a sign, a decimal point, an exponent. Python's own ``int`` and
#: ``float`` also take ``1_000`` and other scripts' digits, which a command line has no use for.
_INTEGER = re.compile(r"[+-]?[0-9]{1,1000}")
_DECIMAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")
#: Words ``float`` reads as a non-finite number.
_NOT_FINITE = ("nan", "inf", "infinity")


def fields(*types: Number | None, append: bool = False) -> type[argparse.Action]:
    """An argparse action for an option of several values (``--start X Y YAW``, ``--shift NAME DX DY``), each
    checked by its own Number (``None``: kept as text); a mistake names the value by its metavar:
    ``--start: YAW: 7 is above the maximum 6.28319``. With ``append`` the option may be repeated."""

    class Fields(argparse.Action):
        def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                     values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
            texts = list(values) if isinstance(values, Sequence) and not isinstance(values, str) else [values]
            names = self.metavar if isinstance(self.metavar, tuple) else (self.metavar,) * len(texts)
            checked: list[Any] = []
            for text, kind, name in zip(texts, types, names, strict=False):
                if kind is None:
                    checked.append(text)
                    continue
                try:
                    checked.append(kind.parse(str(text)))
                except NumberError as exc:
                    raise argparse.ArgumentError(self, f"{name}: {exc}") from None
            if append:
                checked = [*(getattr(namespace, self.dest, None) or []), checked]
            setattr(namespace, self.dest, checked)

    return Fields


_ARGUMENT = re.compile(r"^argument ([^:]+): ")


def one_line(message: str) -> str:
    """argparse's message in the project's shape: ``argument --max-frames/-n: ...`` becomes
    ``--max-frames: ...`` (the long name), and nothing the user typed can break the line."""
    match = _ARGUMENT.match(message)
    if match:
        names = match.group(1).split("/")
        name = next((n for n in names if n.startswith("--")), names[0])
        message = f"{name}: {message[match.end():]}"
    return printable(message, limit=400)


#: What argparse takes for a negative number rather than an option: besides ``-1`` and ``-.5`` also ``-1e5``,
#: ``-inf`` and ``-nan``, so that the option refuses them with its own reason instead of "expected one argument".
_NEGATIVE = re.compile(r"^-([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


class CommandLineParser(argparse.ArgumentParser):
    """argparse whose every mistake is one line on stderr, ``PROG: error: --option: why``, exit code 2."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE

    def error(self, message: str) -> NoReturn:
        self.exit(USAGE_ERROR, f"{self.prog}: error: {one_line(message)}\n")


def check_limit_settings() -> None:
    """Read every ``OBJREC_MAX_*`` variable now, so that a bad one is refused before any work starts
    (``strictio.limits.LimitSettingError``, an InputError) rather than deep inside a reader."""
    for limit in ALL_LIMITS:
        limit.value()
