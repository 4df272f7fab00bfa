"""Rules between parameters, declared beside them instead of hand-coded in each module.

    min_radius = Float(...)
    max_radius = Float(...)
    radius_order = Ordered("min_radius", "max_radius")

Validation (``set_parameters``, loading a file) enforces every declared rule with a message that names both
parameters; a module may still add its own ``check_values`` for what a rule cannot say.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from .parameters import ParameterError, short_repr


class Rule:
    """A condition on several parameters' values; ``check`` raises ParameterError when it fails."""

    names: tuple[str, ...] = ()

    def __set_name__(self, owner: type, name: str) -> None:
        self.attribute = name

    def check(self, values: Mapping[str, Any], module: str) -> None:
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError


class Ordered(Rule):
    """``low <= high`` (or ``low < high`` when ``strict``): a minimum never above its maximum."""

    def __init__(self, low: str, high: str, *, strict: bool = False, why: str = "") -> None:
        self.low, self.high, self.strict = low, high, strict
        self.names = (low, high)
        self.why = why

    def describe(self) -> str:
        return f"{self.low} {'<' if self.strict else '<='} {self.high}"

    def check(self, values: Mapping[str, Any], module: str) -> None:
        low, high = values[self.low], values[self.high]
        bad = low >= high if self.strict else low > high
        if bad:
            reason = f"must be {'below' if self.strict else 'at most'} {self.high}={short_repr(high)}"
            if self.why:
                reason += f" ({self.why})"
            raise ParameterError(module, self.low, low, reason)


class Check(Rule):
    """Any condition: ``test(values)`` is true when the values are allowed; ``message`` says why not."""

    def __init__(self, names: tuple[str, ...], test: Callable[[Mapping[str, Any]], bool], message: str) -> None:
        self.names = names
        self.test = test
        self.message = message

    def describe(self) -> str:
        return self.message

    def check(self, values: Mapping[str, Any], module: str) -> None:
        if not self.test(values):
            shown = ", ".join(f"{n}={short_repr(values[n])}" for n in self.names[1:])
            rule = f"{self.message}" + (f" (with {shown})" if shown else "")
            raise ParameterError(module, self.names[0], values[self.names[0]], rule)
