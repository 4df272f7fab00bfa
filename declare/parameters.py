"""Declared, typed, bounded parameters.

A module declares each parameter once, as a class attribute; validation, the parameter file's contents and
the GUI's widgets all come from that one declaration.

- Hard bounds (``min``/``max``, ``None`` for an open side) are what validation allows.
- Soft bounds (``soft_min``/``soft_max``) are the range a slider offers; a typed value may go past them up to
  the hard bounds. They default to the hard bounds.
- ``step`` is enforced for ``Int`` (odd kernel sizes) and only guides widgets for ``Float``.
- ``relevant`` says when a parameter matters (``relevant={"feature_type": ("SIFT",)}``): panels hide it
  otherwise; files keep its value all the same.
- A ``Choice`` may learn at run time that the installed libraries cannot serve some of its values
  (``unavailable``): widgets do not offer them and validation refuses them with the reason.
"""

from __future__ import annotations

import math
import numbers
import reprlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

_short = reprlib.Repr()
_short.maxstring = 60
_short.maxother = 60
_short.maxlist = _short.maxtuple = _short.maxdict = 4
_short.maxlevel = 2

#: Control characters shown escaped in messages, so a value can neither split an error line nor fake output.
_CONTROL = {i: f"\\x{i:02x}" for i in (*range(0x20), 0x7F)} | {0x0A: "\\n", 0x0D: "\\r", 0x09: "\\t"}


def short_repr(value: object) -> str:
    """A value as error messages show it: never the whole of a huge or deeply nested one."""
    return _short.repr(value).translate(_CONTROL)


def printable(text: object, limit: int = 60) -> str:
    """A name from a file as messages show it: control characters escaped, never longer than ``limit``."""
    shown = str(text).translate(_CONTROL)
    return shown if len(shown) <= limit else shown[: limit - 3] + "..."


class ParameterError(ValueError):
    """A value that a module's declaration does not allow; names module, parameter, value and the rule."""

    def __init__(self, module: str, parameter: str, value: object, rule: str) -> None:
        self.module = module
        self.parameter = parameter
        self.value = value
        self.rule = rule
        super().__init__(f"{module}: parameter {parameter}={short_repr(value)} is invalid: {rule}")


Relevance = Mapping[str, Sequence[Any]] | Callable[[Mapping[str, Any]], bool]


class Parameter:
    """One declared parameter: a data descriptor on the module class.

    Reading ``module.h_min`` returns the current value; assigning goes through ``set_parameters`` so it is
    validated and observers are notified.
    """

    type_name = "any"

    def __init__(self, default: Any, doc: str = "", *, relevant: Relevance | None = None) -> None:
        self.name = ""
        self.doc = doc
        self.default = default
        self.relevant = relevant

    def __set_name__(self, owner: type, name: str) -> None:
        self.bind(name, owner.__name__)

    def bind(self, name: str, owner: str) -> Parameter:
        """Name the declaration and check its default (a wrong default is a programming error)."""
        self.name = name
        self.default = self.validate(self.default, owner)
        return self

    def __get__(self, obj: Any, objtype: type | None = None) -> Any:
        if obj is None:
            return self
        return getattr(obj._snapshot, self.name)

    def __set__(self, obj: Any, value: Any) -> None:
        obj.set_parameters(**{self.name: value})

    def validate(self, value: Any, module: str) -> Any:
        """Return the value in canonical form, or raise ParameterError."""
        raise NotImplementedError

    def describe(self) -> str:
        """The allowed values in words, for error messages and tooltips."""
        return self.type_name

    def is_relevant(self, values: Mapping[str, Any]) -> bool:
        """Whether this parameter matters given the other values (panels hide it when it does not)."""
        if self.relevant is None:
            return True
        if callable(self.relevant):
            return bool(self.relevant(values))
        return all(values.get(name) in allowed for name, allowed in self.relevant.items())

    def relevance_text(self) -> str:
        """When the parameter matters, in words (empty when always)."""
        if self.relevant is None:
            return ""
        if callable(self.relevant):
            return "only in some settings"
        return "only when " + " and ".join(
            f"{name} is {' or '.join(map(str, allowed))}" for name, allowed in self.relevant.items()
        )

    def _fail(self, module: str, value: Any, rule: str | None = None) -> ParameterError:
        return ParameterError(module, self.name, value, rule or f"expected {self.describe()}")

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, default={self.default!r}, {self.describe()})"


def _bound_text(value: float | None, fallback: str) -> str:
    if value is None:
        return fallback
    if isinstance(value, int) or (float(value).is_integer() and abs(value) < 1e15):
        return str(int(value))
    return f"{value:g}"


class _Number(Parameter):
    numeric_type: type = float

    def __init__(
        self,
        default: Any,
        doc: str = "",
        *,
        min: float | None = None,
        max: float | None = None,
        soft_min: float | None = None,
        soft_max: float | None = None,
        step: float | None = None,
        relevant: Relevance | None = None,
    ) -> None:
        if min is not None and max is not None and min > max:
            raise ValueError(f"min {min} > max {max}")
        if step is not None and step <= 0:
            raise ValueError(f"step {step} must be positive")
        self.min = min
        self.max = max
        self.soft_min = min if soft_min is None else soft_min
        self.soft_max = max if soft_max is None else soft_max
        for soft in (soft_min, soft_max):
            if soft is not None and ((min is not None and soft < min) or (max is not None and soft > max)):
                raise ValueError(f"soft bound {soft} lies outside the hard bounds {min}..{max}")
        if self.soft_min is not None and self.soft_max is not None and self.soft_min > self.soft_max:
            raise ValueError(f"soft_min {self.soft_min} > soft_max {self.soft_max}")
        self.step = step
        super().__init__(default, doc, relevant=relevant)

    @property
    def slider_range(self) -> tuple[float, float] | None:
        """The range a slider offers (the soft bounds), or None where a side is open."""
        if self.soft_min is None or self.soft_max is None:
            return None
        return self.soft_min, self.soft_max

    def describe(self) -> str:
        text = f"{self.type_name} in {_bound_text(self.min, '-inf')}..{_bound_text(self.max, 'inf')}"
        if self.enforced_step is not None:
            text += f" in steps of {_bound_text(self.step, '1')} from {_bound_text(self.min, '0')}"
        return text

    @property
    def enforced_step(self) -> float | None:
        return None

    def _check_bounds(self, value: float, module: str) -> None:
        if (self.min is not None and value < self.min) or (self.max is not None and value > self.max):
            raise self._fail(module, value, f"out of range, allowed {self.describe()}")


class Int(_Number):
    """An integer with optional bounds; a step (e.g. 2 from 1 for odd kernel sizes) is enforced."""

    type_name = "int"
    numeric_type = int

    @property
    def enforced_step(self) -> int | None:
        return int(self.step) if self.step not in (None, 1) else None

    def validate(self, value: Any, module: str) -> int:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            if isinstance(value, numbers.Real) and not isinstance(value, bool):
                if not math.isfinite(value):
                    raise self._fail(module, value, "expected a finite integer")
                if float(value).is_integer():
                    raise self._fail(module, value, f"expected an integer, got {type(value).__name__} {value!r}")
            raise self._fail(module, value, f"expected an integer, got {type(value).__name__}")
        value = int(value)
        self._check_bounds(value, module)
        step = self.enforced_step
        if step is not None:
            base = self.min if self.min is not None else 0
            if (value - base) % step:
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
        try:
            value = float(value)
        except OverflowError:
            raise self._fail(module, value, "expected a finite number") from None
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
        return str(value)


class Choice(Parameter):
    """One value out of a fixed list (an enum); widgets show it as a combo box.

    ``unavailable`` is called (once, lazily) for the choices this installation cannot serve, as
    ``{choice: reason}``; validation refuses those with the reason and widgets leave them out.
    """

    type_name = "choice"

    def __init__(
        self,
        default: str,
        choices: Sequence[str],
        doc: str = "",
        *,
        unavailable: Callable[[], Mapping[str, str]] | None = None,
        relevant: Relevance | None = None,
    ) -> None:
        if not choices:
            raise ValueError("a Choice needs at least one choice")
        self.choices = tuple(choices)
        self._unavailable_source = unavailable
        self._unavailable: dict[str, str] | None = None if unavailable else {}
        super().__init__(default, doc, relevant=relevant)

    def bind(self, name: str, owner: str) -> Parameter:
        self.name = name
        if self.default not in self.choices:
            raise ValueError(f"{owner}.{name}: default {self.default!r} is not one of {self.choices}")
        return self  # the default is checked for availability when a module is made, not at import

    @property
    def unavailable(self) -> dict[str, str]:
        """``{choice: reason}`` for the choices the installed libraries cannot serve."""
        if self._unavailable is None:
            found = dict(self._unavailable_source()) if self._unavailable_source else {}
            self._unavailable = {k: v for k, v in found.items() if k in self.choices}
        return self._unavailable

    @property
    def available_choices(self) -> tuple[str, ...]:
        missing = self.unavailable
        return tuple(c for c in self.choices if c not in missing)

    def describe(self) -> str:
        return "one of " + ", ".join(self.available_choices)

    def validate(self, value: Any, module: str) -> str:
        if not isinstance(value, str) or value not in self.choices:
            raise self._fail(module, value, self.describe())
        reason = self.unavailable.get(value)
        if reason is not None:
            raise self._fail(module, value, f"not available here: {reason}")
        return str(value)  # a str subclass (numpy.str_) would not save as YAML
