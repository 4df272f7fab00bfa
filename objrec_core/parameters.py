"""Declared, typed, bounded parameters.

A module declares each parameter once, as a class attribute; validation, the parameter file's contents and
the GUI's widgets all come from that one declaration (the seed wrote each of them by hand per module).
"""

from __future__ import annotations

import math
import numbers
import reprlib
from collections.abc import Sequence
from typing import Any

_short = reprlib.Repr()
_short.maxstring = 60
_short.maxother = 60
_short.maxlist = _short.maxtuple = _short.maxdict = 4
_short.maxlevel = 2


def short_repr(value: object) -> str:
    """A value as error messages show it: never the whole of a huge or deeply nested one."""
    return _short.repr(value)


class ParameterError(ValueError):
    """A value that a module's declaration does not allow; names module, parameter, value and the rule."""

    def __init__(self, module: str, parameter: str, value: object, rule: str) -> None:
        self.module = module
        self.parameter = parameter
        self.value = value
        self.rule = rule
        super().__init__(f"{module}: parameter {parameter}={short_repr(value)} is invalid: {rule}")


class Parameter:
    """One declared parameter: a data descriptor on the module class.

    Reading ``module.h_min`` returns the current value; assigning goes through ``set_parameters`` so it is
    validated and observers are notified.
    """

    type_name = "any"

    def __init__(self, default: Any, doc: str = "") -> None:
        self.name = ""
        self.doc = doc
        self.default = default

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name
        # The default must satisfy the declaration itself: a wrong default is a programming error.
        self.default = self.validate(self.default, owner.__name__)

    def __get__(self, obj: Any, objtype: type | None = None) -> Any:
        if obj is None:
            return self
        return obj._values[self.name]

    def __set__(self, obj: Any, value: Any) -> None:
        obj.set_parameters(**{self.name: value})

    def validate(self, value: Any, module: str) -> Any:
        """Return the value in canonical form, or raise ParameterError."""
        raise NotImplementedError

    def describe(self) -> str:
        """The allowed values in words, for error messages and tooltips."""
        return self.type_name

    def _fail(self, module: str, value: Any, rule: str | None = None) -> ParameterError:
        return ParameterError(module, self.name, value, rule or f"expected {self.describe()}")

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, default={self.default!r}, {self.describe()})"


class _Number(Parameter):
    def __init__(
        self,
        default: Any,
        doc: str = "",
        *,
        min: float | None = None,
        max: float | None = None,
        step: float | None = None,
    ) -> None:
        if min is not None and max is not None and min > max:
            raise ValueError(f"min {min} > max {max}")
        self.min = min
        self.max = max
        self.step = step
        super().__init__(default, doc)

    def describe(self) -> str:
        lo = "-inf" if self.min is None else f"{self.min:g}"
        hi = "inf" if self.max is None else f"{self.max:g}"
        text = f"{self.type_name} in {lo}..{hi}"
        if self.step is not None and self.type_name == "int" and self.step != 1:
            text += f" in steps of {self.step:g} from {self.min:g}"
        return text

    def _check_bounds(self, value: float, module: str) -> None:
        if (self.min is not None and value < self.min) or (self.max is not None and value > self.max):
            raise self._fail(module, value, f"out of range, allowed {self.describe()}")


class Int(_Number):
    """An integer with optional bounds; a step (e.g. 2 from 1 for odd kernel sizes) is enforced."""

    type_name = "int"

    def validate(self, value: Any, module: str) -> int:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise self._fail(module, value, f"expected an integer, got {type(value).__name__}")
        value = int(value)
        self._check_bounds(value, module)
        if self.step not in (None, 1):
            base = self.min if self.min is not None else 0
            if (value - base) % self.step:
                raise self._fail(module, value, f"not allowed, {self.describe()}")
        return value


class Float(_Number):
    """A finite real number with optional bounds; the step only guides widgets."""

    type_name = "float"

    def validate(self, value: Any, module: str) -> float:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            hint = ""
            if isinstance(value, str):
                try:
                    float(value)
                    hint = " (YAML reads 1e3 as text: write 1.0e3 or 1000.0)"
                except ValueError:
                    pass
            raise self._fail(module, value, f"expected a number, got {type(value).__name__}{hint}")
        value = float(value)
        if not math.isfinite(value):
            raise self._fail(module, value, "expected a finite number")
        self._check_bounds(value, module)
        return value


class Bool(Parameter):
    """True or false; strings such as "yes" are refused rather than guessed."""

    type_name = "bool"

    def validate(self, value: Any, module: str) -> bool:
        if not isinstance(value, bool):
            raise self._fail(module, value, f"expected true or false, got {type(value).__name__}")
        return value


class Str(Parameter):
    """Free text."""

    type_name = "str"

    def validate(self, value: Any, module: str) -> str:
        if not isinstance(value, str):
            raise self._fail(module, value, f"expected text, got {type(value).__name__}")
        return value


class Choice(Parameter):
    """One value out of a fixed list (an enum); widgets show it as a combo box."""

    type_name = "choice"

    def __init__(self, default: str, choices: Sequence[str], doc: str = "") -> None:
        if not choices:
            raise ValueError("a Choice needs at least one choice")
        self.choices = tuple(choices)
        super().__init__(default, doc)

    def describe(self) -> str:
        return "one of " + ", ".join(self.choices)

    def validate(self, value: Any, module: str) -> str:
        if not isinstance(value, str) or value not in self.choices:
            raise self._fail(module, value, self.describe())
        return str(value)  # a str subclass (numpy.str_) would not save as YAML
