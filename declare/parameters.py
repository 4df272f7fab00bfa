"""Declared, typed, bounded parameters.

A module declares each parameter once, as a class attribute; validation, the parameter file's contents and
the GUI's widgets all come from that one declaration.

- Hard bounds (``min``/``max``, ``None`` for an unbounded side) are what validation allows; ``min_open`` /
  ``max_open`` exclude the bound itself (``Float(0.5, min=0.0, min_open=True, max=1.0)``: "float in (0..1]").
- ``optional=True`` allows None ("no limit", "to the end"); ``deprecated={0: None}`` keeps an old sentinel
  readable (accepted, logged, replaced).
- Soft bounds (``soft_min``/``soft_max``) are the range a slider offers; a typed value may go past them up to
  the hard bounds. They default to the hard bounds.
- ``step`` is enforced for ``Int`` (odd kernel sizes) and only guides widgets for ``Float``.
- ``relevant`` says when a parameter matters (``relevant={"feature_type": ("SIFT",)}``): panels hide it
  otherwise; files keep its value all the same.
- A ``Choice`` may learn at run time that the installed libraries cannot serve some of its values
  (``unavailable``): widgets do not offer them and validation refuses them with the reason.
- Each class owns what its values mean: ``parse_text`` (source options, command lines), ``invalid_examples``,
  ``boundary_values`` and ``alternatives`` (the conformance suite's values) and ``describe``; a plug-in adds
  a type by subclassing ``Parameter``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from typing import Any

# the one home of showing untrusted text; re-exported here for the modules that import them from declare
from strictio.shown import printable as printable
from strictio.shown import short_repr as short_repr


class ParameterError(ValueError):
    """A value that a module's declaration does not allow; names module, parameter, value and the rule."""

    def __init__(self, module: str, parameter: str, value: object, rule: str) -> None:
        self.module = module
        self.parameter = parameter
        self.value = value
        self.rule = rule
        super().__init__(f"{module}: parameter {parameter}={short_repr(value)} is invalid: {rule}")


Relevance = Mapping[str, Sequence[Any]] | Callable[[Mapping[str, Any]], bool]

#: The words that stand for "no value" in text (a source option, a command line) for an optional parameter.
NONE_WORDS = ("none", "null")


def same_value(a: Any, b: Any) -> bool:
    """Equal and of the same type, NaN equal to NaN: 1 and 1.0 and True are three different values here."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


def unique_values(values: Sequence[Any]) -> list[Any]:
    """The values without repeats (``same_value``), in their order."""
    found: list[Any] = []
    for value in values:
        if not any(same_value(value, f) for f in found):
            found.append(value)
    return found


def _same_sentinel(value: Any, old: Any) -> bool:
    """``value`` is the deprecated ``old``: the same value, or a whole number for a Float's (a file's 0 for 0.0)."""
    return same_value(value, old) or (type(value) is int and type(old) is float and value == old)


class Parameter:
    """One declared parameter: a data descriptor on the module class.

    Reading ``module.h_min`` returns the current value; assigning goes through ``set_parameters`` so it is
    validated and observers are notified.

    What a type of value means lives here, not in ladders of ``isinstance`` elsewhere, so a plug-in adds a
    type by subclassing: ``validate_value`` (the canonical value or ParameterError), ``from_text`` (a source
    option's or a command line's text as a value), ``invalid_examples``, ``boundary_values`` and
    ``alternatives`` (what the conformance suite tries) and ``describe``.

    ``optional=True`` allows None ("no value": no limit, to the end, automatic), written ``null`` in YAML and
    ``none`` in text. ``deprecated={0: None}`` keeps an old sentinel readable: the value is accepted, logged
    as deprecated, and replaced.
    """

    type_name = "any"

    def __init__(
        self,
        default: Any,
        doc: str = "",
        *,
        optional: bool = False,
        deprecated: Mapping[Any, Any] | None = None,
        relevant: Relevance | None = None,
    ) -> None:
        self.name = ""
        self.doc = doc
        self.default = default
        self.optional = optional
        self.deprecated = dict(deprecated or {})
        self.relevant = relevant

    def __set_name__(self, owner: type, name: str) -> None:
        self.bind(name, owner.__name__)

    def bind(self, name: str, owner: str) -> Parameter:
        """Name the declaration and check its default (a wrong default is a programming error)."""
        self.name = name
        self.default = self.validate(self.default, owner)
        return self

    def with_default(self, default: Any, owner: str) -> Parameter:
        """This declaration with another default (a subclass's ``h_min = 10``), checked against it."""
        changed = object.__new__(type(self))
        changed.__dict__.update(self.__dict__)
        changed.default = default
        return changed.bind(self.name, owner)

    def __get__(self, obj: Any, objtype: type | None = None) -> Any:
        if obj is None:
            return self
        return getattr(obj._snapshot, self.name)

    def __set__(self, obj: Any, value: Any) -> None:
        obj.set_parameters(**{self.name: value})

    # -- validation ---------------------------------------------------------------------------------------
    def validate(self, value: Any, module: str) -> Any:
        """Return the value in canonical form, or raise ParameterError: a deprecated sentinel is replaced,
        None is allowed when the parameter is optional, anything else goes to ``validate_value``."""
        if self.deprecated:
            value = self._replace_deprecated(value, module)
        if value is None and self.optional:
            return None
        return self.validate_value(value, module)

    def validate_value(self, value: Any, module: str) -> Any:
        """A value other than None as its canonical form, or raise ParameterError (each type says how)."""
        raise NotImplementedError

    def _replace_deprecated(self, value: Any, module: str) -> Any:
        for old, new in self.deprecated.items():
            if _same_sentinel(value, old):
                import logging  # only on this rare path, so the floor imports nothing it seldom needs

                logging.getLogger(__name__).warning(
                    "%s: %s=%s is deprecated; write %s", module or "option", self.name, short_repr(value),
                    "none" if new is None else short_repr(new))
                return new
        return value

    def is_deprecated(self, value: Any) -> bool:
        """Whether ``value`` is an old sentinel this declaration still reads (and replaces)."""
        return any(_same_sentinel(value, old) for old in self.deprecated)

    # -- text ---------------------------------------------------------------------------------------------
    def parse_text(self, text: str, module: str = "") -> Any:
        """A value given as text (``frames=100`` in a source spec, a command line) as a valid value, or one
        ParameterError naming module, parameter and text; ``none``/``null`` for an optional parameter."""
        stripped = text.strip()
        if self.optional and stripped.lower() in NONE_WORDS:
            return None
        try:
            value = self.from_text(stripped)
        except NotImplementedError:
            raise self._fail(module, text, f"{self.type_name} values cannot be given as text") from None
        except (ValueError, TypeError, OverflowError):
            raise self._fail(module, text, f"expected {self.describe()}") from None
        return self.validate(value, module)

    def from_text(self, text: str) -> Any:
        """The value ``text`` stands for, before validation; ValueError when it stands for none."""
        raise NotImplementedError

    def invalid_texts(self) -> list[tuple[str, str]]:
        """Texts ``parse_text`` must refuse, each with what makes it wrong (a source's conformance check
        writes them into specs). Empty unless the type says: text may be more lenient than values."""
        return []

    # -- what the conformance suite tries -----------------------------------------------------------------
    def invalid_examples(self) -> list[tuple[str, Any]]:
        """Values this declaration must refuse, each with what makes it wrong. A subclass adds its own to
        ``super().invalid_examples()`` (which holds None unless the parameter is optional)."""
        return [] if self.optional else [("None", None)]

    def boundary_values(self) -> list[Any]:
        """Valid values at the edges of what the declaration allows or a panel offers (None if optional)."""
        return [None] if self.optional else []

    def alternatives(self, default: Any) -> list[Any]:
        """Valid values other than ``default``, best first (for change events and file round trips)."""
        return [None] if self.optional and default is not None else []

    def example(self) -> Any:
        """A valid value that is not None: the default, else the first boundary value."""
        if self.default is not None:
            return self.default
        return next(v for v in self.boundary_values() if v is not None)

    # -- words --------------------------------------------------------------------------------------------
    def describe(self) -> str:
        """The allowed values in words, for error messages and tooltips."""
        return self.describe_value() + (", or none" if self.optional else "")

    def describe_value(self) -> str:
        """The allowed values other than None, in words (each type says how)."""
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
    """A number with hard bounds (each closed, or open with ``min_open``/``max_open``), soft bounds for a
    slider, and a step."""

    numeric_type: type = float

    def __init__(
        self,
        default: Any,
        doc: str = "",
        *,
        min: float | None = None,
        max: float | None = None,
        min_open: bool = False,
        max_open: bool = False,
        soft_min: float | None = None,
        soft_max: float | None = None,
        step: float | None = None,
        optional: bool = False,
        deprecated: Mapping[Any, Any] | None = None,
        relevant: Relevance | None = None,
    ) -> None:
        if min is not None and max is not None and (min > max or (min == max and (min_open or max_open))):
            raise ValueError(f"the interval from min {min} to max {max} holds no value")
        if (min_open and min is None) or (max_open and max is None):
            raise ValueError("an open bound needs its value (min_open needs min, max_open needs max)")
        if step is not None and step <= 0:
            raise ValueError(f"step {step} must be positive")
        self.min = min
        self.max = max
        self.min_open = min_open
        self.max_open = max_open
        self.soft_min = min if soft_min is None else soft_min
        self.soft_max = max if soft_max is None else soft_max
        for soft in (soft_min, soft_max):
            if soft is not None and ((min is not None and soft < min) or (max is not None and soft > max)):
                raise ValueError(f"soft bound {soft} lies outside the hard bounds {min}..{max}")
        if self.soft_min is not None and self.soft_max is not None and self.soft_min > self.soft_max:
            raise ValueError(f"soft_min {self.soft_min} > soft_max {self.soft_max}")
        self.step = step
        super().__init__(default, doc, optional=optional, deprecated=deprecated, relevant=relevant)

    @property
    def slider_range(self) -> tuple[float, float] | None:
        """The range a slider offers (the soft bounds), or None where a side is open. An end that is also an
        open hard bound is itself excluded: widgets start just inside it."""
        if self.soft_min is None or self.soft_max is None:
            return None
        return self.soft_min, self.soft_max

    def interval_text(self) -> str:
        """The hard bounds: ``0..1`` when closed (or unbounded), ``(0..1]`` when a bound is excluded."""
        low, high = _bound_text(self.min, "-inf"), _bound_text(self.max, "inf")
        if not (self.min_open or self.max_open):
            return f"{low}..{high}"
        left = "(" if self.min_open or self.min is None else "["
        right = ")" if self.max_open or self.max is None else "]"
        return f"{left}{low}..{high}{right}"

    def describe_value(self) -> str:
        text = f"{self.type_name} in {self.interval_text()}"
        if self.enforced_step is not None:
            text += f" in steps of {_bound_text(self.step, '1')} from {_bound_text(self.min, '0')}"
        return text

    @property
    def enforced_step(self) -> float | None:
        return None

    def below_min(self, value: float) -> bool:
        return self.min is not None and (value <= self.min if self.min_open else value < self.min)

    def above_max(self, value: float) -> bool:
        return self.max is not None and (value >= self.max if self.max_open else value > self.max)

    def _check_bounds(self, value: float, module: str) -> None:
        if self.below_min(value) or self.above_max(value):
            raise self._fail(module, value, f"out of range, allowed {self.describe()}")

    def example(self) -> Any:
        """The default, else the first boundary value, else a small number the bounds allow."""
        if self.default is not None:
            return self.default
        for value in (*self.boundary_values(), 0, 1, -1):
            if value is not None and not self.below_min(value) and not self.above_max(value):
                return self.numeric_type(value)
        raise ValueError(f"{self.name}: no valid value to give as an example")

    def invalid_texts(self) -> list[tuple[str, str]]:
        """The invalid examples that are numbers of this type, written out (past a bound, off the step,
        NaN), then text that is no number at all."""
        texts = [(why, repr(value)) for why, value in self.invalid_examples()
                 if type(value) is self.numeric_type or (type(value) is int and self.numeric_type is float)]
        return [*texts, ("not a number", "many"), ("nothing", "")]

    def _inside(self, bound: float, upward: bool) -> Any:
        """The allowed value nearest a bound, towards the inside: the bound itself unless it is excluded."""
        raise NotImplementedError

    def boundary_values(self) -> list[Any]:
        """Hard and soft bounds, each moved just inside where it is excluded (or off the step)."""
        ends = ((self.min, True), (self.max, False), (self.soft_min, True), (self.soft_max, False))
        values = [self._inside(bound, upward) for bound, upward in ends if bound is not None]
        values = [v for v in values if not self.below_min(v) and not self.above_max(v)]
        return [v for v in unique_values(values) if not self.is_deprecated(v)] + super().boundary_values()

    def alternatives(self, default: Any) -> list[Any]:
        """Best first: a step from the default towards the middle of the slider's range (near the default, so
        a slow extreme does not make every check slow, and a fraction for floats, so a file must keep every
        digit); then the middle and the bounds; None where optional. From None, the first valid value."""
        reference = self.example() if default is None else default
        found = self._near(reference)
        if default is None:
            found = unique_values([reference, *found])
        return [v for v in found if not self.is_deprecated(v)] + super().alternatives(default)

    def _near(self, reference: Any) -> list[Any]:
        lo, hi = self.soft_min, self.soft_max
        middle = lo + (hi - lo) / 2 if lo is not None and hi is not None else None
        towards = 1 if middle is None or middle >= reference else -1
        candidates = self._steps_from(reference, middle, towards)
        if middle is not None:
            candidates.append(middle)
        candidates += [b for b in (lo, hi, self.min, self.max) if b is not None]
        found: list[Any] = []
        for candidate in candidates:
            try:
                value = self.validate_value(self._candidate(candidate), "")
            except (ParameterError, OverflowError, ValueError):
                continue
            if not same_value(value, reference) and not any(same_value(value, f) for f in found):
                found.append(value)
        return found

    def _steps_from(self, reference: Any, middle: float | None, towards: int) -> list[float]:
        raise NotImplementedError

    def _candidate(self, value: float) -> Any:
        return self.numeric_type(value)


class Int(_Number):
    """An integer with optional bounds; a step (e.g. 2 from 1 for odd kernel sizes) is enforced, counted from
    ``min`` (or 0)."""

    type_name = "int"
    numeric_type = int

    @property
    def enforced_step(self) -> int | None:
        return int(self.step) if self.step not in (None, 1) else None

    @property
    def step_origin(self) -> int:
        """Where the enforced step counts from: ``min`` (even when it is excluded), else 0."""
        return int(self.min) if self.min is not None else 0

    def snap_to_step(self, value: int, down: bool) -> int:
        """The nearest value the enforced step allows, below (``down``) or above ``value``."""
        step = self.enforced_step
        if step is None:
            return value
        offset = (value - self.step_origin) % step
        if not offset:
            return value
        return value - offset if down else value + (step - offset)

    def validate_value(self, value: Any, module: str) -> int:
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
        if step is not None and (value - self.step_origin) % step:
            raise self._fail(module, value, f"not allowed, {self.describe()}")
        return value

    def from_text(self, text: str) -> int:
        return int(text)

    def invalid_texts(self) -> list[tuple[str, str]]:
        return [*super().invalid_texts(), ("a fraction", "1.5")]

    def _inside(self, bound: float, upward: bool) -> int:
        value = int(bound)
        if upward and self.min_open and bound == self.min:
            value += 1
        elif not upward and self.max_open and bound == self.max:
            value -= 1
        return self.snap_to_step(value, down=not upward)

    def invalid_examples(self) -> list[tuple[str, Any]]:
        bad: list[tuple[str, Any]] = []
        if self.min is not None:
            low = int(self.min) if self.min_open else int(self.min) - 1
            while self.is_deprecated(low):  # an old sentinel just outside (frames=0) is accepted: go past it
                low -= 1
            bad.append(("the excluded minimum", low) if low == self.min else
                       ("one below the hard minimum", low) if low == self.min - 1 else ("below the hard minimum", low))
        if self.max is not None:
            high = int(self.max) if self.max_open else int(self.max) + 1
            while self.is_deprecated(high):
                high += 1
            bad.append(("the excluded maximum", high) if high == self.max else
                       ("one above the hard maximum", high) if high == self.max + 1 else
                       ("above the hard maximum", high))
        step = self.enforced_step
        if step is not None:
            off = self.step_origin + 1
            if not self.below_min(off) and not self.above_max(off):
                bad.append((f"off the step of {step}", off))
        sample = self.example()
        bad += [("text for a number", str(sample)), ("a fractional float", float(sample) + 0.5),
                ("a whole float", float(sample)), ("a bool", True)]
        bad += [("NaN", math.nan), ("+inf", math.inf), ("-inf", -math.inf)]
        return [b for b in bad if not self.is_deprecated(b[1])] + super().invalid_examples()

    def _steps_from(self, reference: Any, middle: float | None, towards: int) -> list[float]:
        step = self.enforced_step or 1
        return [reference + towards * step, reference - towards * step]

    def _candidate(self, value: float) -> int:
        return self.snap_to_step(int(value), down=True)


class Float(_Number):
    """A finite real number with optional bounds (closed, or open: ``min=0.0, min_open=True`` for "above
    zero"); the step only guides widgets."""

    type_name = "float"

    def validate_value(self, value: Any, module: str) -> float:
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

    def from_text(self, text: str) -> float:
        return float(text)

    def _inside(self, bound: float, upward: bool) -> float:
        value = float(bound)
        if upward and self.min_open and bound == self.min:
            return math.nextafter(value, math.inf)
        if not upward and self.max_open and bound == self.max:
            return math.nextafter(value, -math.inf)
        return value

    def invalid_examples(self) -> list[tuple[str, Any]]:
        bad: list[tuple[str, Any]] = []
        if self.min is not None:
            bad.append(("the excluded minimum", float(self.min)) if self.min_open
                       else ("just below the hard minimum", math.nextafter(float(self.min), -math.inf)))
            if self.is_deprecated(bad[-1][1]):  # an old sentinel there (end=0) is accepted: one below it is not
                bad.append(("below the hard minimum", float(self.min) - 1.0))
        if self.max is not None:
            bad.append(("the excluded maximum", float(self.max)) if self.max_open
                       else ("just above the hard maximum", math.nextafter(float(self.max), math.inf)))
            if self.is_deprecated(bad[-1][1]):
                bad.append(("above the hard maximum", float(self.max) + 1.0))
        bad += [("text for a number", str(self.example())), ("a bool", True), ("NaN", math.nan),
                ("+inf", math.inf), ("-inf", -math.inf)]
        return [b for b in bad if not self.is_deprecated(b[1])] + super().invalid_examples()

    def _steps_from(self, reference: Any, middle: float | None, towards: int) -> list[float]:
        candidates = []
        if middle is not None and middle != reference:
            candidates.append(reference + (middle - reference) / 7)
        return [*candidates, reference + towards / 7, reference - towards / 7, reference * 8 / 7]


#: What text stands for true and false in a source option or on a command line.
_TRUE_WORDS = ("1", "true", "yes", "on")
_FALSE_WORDS = ("0", "false", "no", "off")


class Bool(Parameter):
    """True or false; strings such as "yes" are refused rather than guessed (text options read them)."""

    type_name = "bool"

    def validate_value(self, value: Any, module: str) -> bool:
        if not isinstance(value, bool):
            raise self._fail(module, value, f"expected true or false, got {type(value).__name__}")
        return value

    def from_text(self, text: str) -> bool:
        lowered = text.lower()
        if lowered in _TRUE_WORDS:
            return True
        if lowered in _FALSE_WORDS:
            return False
        raise ValueError(text)

    def invalid_examples(self) -> list[tuple[str, Any]]:
        return [("1 for a bool", 1), ("0 for a bool", 0), ("text for a bool", "true"), *super().invalid_examples()]

    def invalid_texts(self) -> list[tuple[str, str]]:
        return [("neither true nor false", "maybe"), ("a number other than 0 and 1", "2"), ("nothing", "")]

    def boundary_values(self) -> list[Any]:
        return [False, True, *super().boundary_values()]

    def alternatives(self, default: Any) -> list[Any]:
        return ([False, True] if default is None else [not default]) + super().alternatives(default)


class Str(Parameter):
    """Free text."""

    type_name = "str"

    def validate_value(self, value: Any, module: str) -> str:
        if not isinstance(value, str):
            raise self._fail(module, value, f"expected text, got {type(value).__name__}")
        if any("\ud800" <= c <= "\udfff" for c in value):  # a lone surrogate: not text, and OpenCV crashes on it
            raise self._fail(module, value, "expected text, got a lone surrogate (bytes that are not UTF-8)")
        return str(value)

    def from_text(self, text: str) -> str:
        return text

    def invalid_examples(self) -> list[tuple[str, Any]]:
        return [("a number for text", 1), ("a float for text", 1.5), *super().invalid_examples()]

    def boundary_values(self) -> list[Any]:
        return unique_values(["", self.default if self.default is not None else "text"]) + super().boundary_values()

    def alternatives(self, default: Any) -> list[Any]:
        return [f"{default}-other" if default else "other", *super().alternatives(default)]


class Choice(Parameter):
    """One value out of a fixed list (an enum); widgets show it as a combo box.

    ``unavailable`` is called (once, lazily) for the choices this installation cannot serve, as
    ``{choice: reason}``; validation refuses those with the reason and widgets leave them out.
    """

    type_name = "choice"

    def __init__(
        self,
        default: str | None,
        choices: Sequence[str],
        doc: str = "",
        *,
        unavailable: Callable[[], Mapping[str, str]] | None = None,
        optional: bool = False,
        relevant: Relevance | None = None,
    ) -> None:
        if not choices:
            raise ValueError("a Choice needs at least one choice")
        self.choices = tuple(choices)
        self._unavailable_source = unavailable
        self._unavailable: dict[str, str] | None = None if unavailable else {}
        super().__init__(default, doc, optional=optional, relevant=relevant)

    def bind(self, name: str, owner: str) -> Parameter:
        self.name = name
        if self.default not in self.choices and not (self.optional and self.default is None):
            raise ParameterError(owner, name, self.default, f"the default is not one of {', '.join(self.choices)}")
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

    def describe_value(self) -> str:
        return "one of " + ", ".join(self.available_choices)

    def validate_value(self, value: Any, module: str) -> str:
        if not isinstance(value, str) or value not in self.choices:
            raise self._fail(module, value, self.describe())
        reason = self.unavailable.get(value)
        if reason is not None:
            raise self._fail(module, value, f"not available here: {reason}")
        return str(value)  # a str subclass (numpy.str_) would not save as YAML

    def from_text(self, text: str) -> str:
        return text

    def invalid_texts(self) -> list[tuple[str, str]]:
        """The invalid examples that are text (unknown, wrongly cased, unavailable choices)."""
        return [(why, value) for why, value in self.invalid_examples() if isinstance(value, str)]

    def invalid_examples(self) -> list[tuple[str, Any]]:
        unknown = "no-such-choice"
        while unknown in self.choices:
            unknown += "-really"
        bad: list[tuple[str, Any]] = [("an unknown choice", unknown), ("a number for a choice", 1)]
        sample = self.example()
        for variant in (sample.upper(), sample.lower()):
            if variant not in self.choices:
                bad.append(("a choice in the wrong case", variant))
                break
        bad += [(f"an unavailable choice ({reason})", choice) for choice, reason in self.unavailable.items()]
        return bad + super().invalid_examples()

    def boundary_values(self) -> list[Any]:
        return [*self.available_choices, *super().boundary_values()]

    def alternatives(self, default: Any) -> list[Any]:
        return [c for c in self.available_choices if c != default] + super().alternatives(default)
