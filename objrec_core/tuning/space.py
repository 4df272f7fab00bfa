"""The search space of a recognition system, read from its modules' declarations.

A tuning search may only try what a person could set in a panel: the declarations already say which values
a parameter takes (bounds, steps, choices, None where optional) and when it matters (relevance), so the space
is derived from them and a plug-in module is tunable with no extra code. Nothing here imports Optuna: the
conformance suite checks a module's space without the ``tune`` extra, and :mod:`.search` turns each
:class:`Dimension` into an Optuna suggestion.

How each declaration becomes a dimension:

- ``Int``/``Float``: from the soft bounds (the slider's range, which default to the hard ones), so a search
  stays where a person would look; an excluded bound is moved one step inside (a millionth of the range
  where a ``Float`` declares no step). ``Int`` keeps its enforced step (odd kernel sizes). A range over two
  orders of magnitude or more above zero is searched on a log scale; otherwise a ``Float`` with a declared
  step is searched on the step's grid (the values its slider offers), one without continuously.
- ``Bool``, ``Choice``: their values (a ``Choice``'s available ones); an optional parameter adds None as one
  more choice (a number: a switch "is none", and the number only when it is not).
- ``Str`` and parameter types the search does not know are kept at their values, as are the names a module
  lists in its ``untuned`` class attribute (``{"random_seed": "a seed is no setting to tune"}``) and the
  names a user fixes.

Parameters are named as parameter files name them: ``MODULE_ID.PARAMETER`` (``colour.h_min``); module ids may
hold dots, parameter names never do.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from declare.parameters import Bool, Choice, Float, Int, Parameter, Str, short_repr

from ..parametrizable import Parametrizable

#: A range with ``high / low`` at least this (and ``low`` above zero) is searched on a log scale.
LOG_RATIO = 100.0
#: Significant digits of a float searched on a log scale.
SIGNIFICANT = 3
#: Where a Float's excluded bound declares no step, the bound moves inside by this share of the range.
OPEN_BOUND_SHARE = 1e-6


class SearchSpaceError(ValueError):
    """A declaration the search cannot use (an unbounded number), or a name to fix or search that no module
    has; the message names module, parameter and what to do."""


@dataclass(frozen=True)
class Dimension:
    """One searched parameter of one module.

    ``kind`` is ``"int"``, ``"float"`` or ``"choice"``. Numbers have ``low``/``high`` (inclusive), ``step``
    (None: continuous) and ``log``; choices have ``choices``. ``none_switch`` is set for an optional number:
    None is tried as well, through a switch of its own. ``conditional`` when the declaration says the
    parameter matters only for some values of others (``Parameter.is_relevant``).
    """

    module_id: str
    parameter: str
    spec: Parameter
    kind: str
    low: float | None = None
    high: float | None = None
    step: float | None = None
    log: bool = False
    choices: tuple[Any, ...] = ()
    none_switch: bool = False

    @property
    def key(self) -> str:
        """The name in parameter files and on command lines: ``MODULE_ID.PARAMETER``."""
        return f"{self.module_id}.{self.parameter}"

    @property
    def none_key(self) -> str:
        """The name of the switch that tries None for an optional number."""
        return f"{self.key} is none"

    @property
    def conditional(self) -> bool:
        return self.spec.relevant is not None

    def describe(self) -> str:
        """The searched values in words (for logs and the docs' tables)."""
        if self.kind == "choice":
            return "one of " + ", ".join(short_repr(c) for c in self.choices)
        scale = "log scale" if self.log else f"step {self.step:g}" if self.step else "continuous"
        low, high = (f"{int(b)}" if self.kind == "int" else f"{b:g}" for b in (self.low, self.high))
        text = f"{self.kind} {low}..{high} ({scale})"
        return text + (", or none" if self.none_switch else "")

    def snap(self, value: float) -> Any:
        """A number from the search as the declaration's value: an int; a float on the step's grid with the
        step's digits (0.75, never 0.7500000000000001), or on a log scale to three significant digits (2.16,
        not 2.155427556544752: a file a person reads); kept within the range."""
        assert self.low is not None and self.high is not None
        if self.kind == "int":
            return int(min(max(round(value), self.low), self.high))
        if self.log:
            value = float(f"{value:.{SIGNIFICANT}g}")
        elif self.step:
            value = self.low + round((value - self.low) / self.step) * self.step
            value = round(value, _digits(self.step, self.low))
        return float(min(max(value, self.low), self.high))

    def sample(self, rng: random.Random) -> Any:
        """A value drawn uniformly from the space (the conformance check's points; the search uses Optuna)."""
        if self.kind == "choice":
            return rng.choice(self.choices)
        if self.none_switch and rng.random() < 0.25:
            return None
        assert self.low is not None and self.high is not None
        if self.kind == "int":
            step = int(self.step or 1)
            return int(self.low) + step * rng.randint(0, int((self.high - self.low) // step))
        if self.log:
            return self.snap(math.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        return self.snap(rng.uniform(self.low, self.high))

    def ends(self) -> list[Any]:
        """The extreme values of the space (both ends of a range, every choice)."""
        if self.kind == "choice":
            return list(self.choices)
        return [self.snap(self.low), self.snap(self.high)] + ([None] if self.none_switch else [])  # type: ignore[arg-type]


def _digits(*numbers: float) -> int:
    """Decimal places enough to write each of ``numbers`` exactly as its repr does (at most 12)."""
    most = 0
    for number in numbers:
        text = repr(float(number))
        if "e" in text:
            mantissa, exponent = text.split("e")
            places = len(mantissa.split(".")[1].rstrip("0")) if "." in mantissa else 0
            most = max(most, places - int(exponent))
        else:
            most = max(most, len(text.split(".")[1].rstrip("0")))
    return min(most, 12)


def dimension(module_id: str, spec: Parameter, owner: str = "") -> Dimension | None:
    """The dimension ``spec`` makes, or None for a type the search does not know (kept at its value).

    An unbounded number is a SearchSpaceError naming ``owner`` (the module's label) and the parameter."""
    if isinstance(spec, Bool):
        return Dimension(module_id, spec.name, spec, "choice", choices=(False, True) + ((None,) if spec.optional
                                                                                         else ()))
    if isinstance(spec, Choice):
        choices = spec.available_choices + ((None,) if spec.optional else ())
        return Dimension(module_id, spec.name, spec, "choice", choices=tuple(choices))
    if isinstance(spec, Int | Float):
        return _number_dimension(module_id, spec, owner or module_id)
    return None


def _number_dimension(module_id: str, spec: Int | Float, owner: str) -> Dimension:
    low, high = spec.soft_min, spec.soft_max
    missing = [side for side, bound in (("lower", low), ("upper", high)) if bound is None]
    if missing:
        raise SearchSpaceError(
            f"{owner}: parameter {spec.name} ({spec.describe()}) has no {' or '.join(missing)} bound to search: "
            f"declare {'min/soft_min' if low is None else 'max/soft_max'}, list it in the module's untuned, "
            f"or fix it")
    assert low is not None and high is not None
    if isinstance(spec, Int):
        step = spec.enforced_step or 1
        lo = math.ceil(low) + (1 if spec.min_open and low == spec.min else 0)
        hi = math.floor(high) - (1 if spec.max_open and high == spec.max else 0)
        lo, hi = spec.snap_to_step(lo, down=False), spec.snap_to_step(hi, down=True)
        if lo > hi:
            raise SearchSpaceError(f"{owner}: parameter {spec.name} ({spec.describe()}): its range holds no value")
        log = step == 1 and lo >= 1 and hi / lo >= LOG_RATIO
        return Dimension(module_id, spec.name, spec, "int", lo, hi, step, log, none_switch=spec.optional)
    flo, fhi = float(low), float(high)
    inward = spec.step if spec.step else (fhi - flo) * OPEN_BOUND_SHARE
    if spec.min_open and flo == spec.min:
        flo += inward
    if spec.max_open and fhi == spec.max:
        fhi -= inward
    if not flo < fhi:
        raise SearchSpaceError(f"{owner}: parameter {spec.name} ({spec.describe()}): its range holds no value")
    log = flo > 0 and fhi / flo >= LOG_RATIO
    step = None if log or not spec.step else float(spec.step)
    if step is not None:
        fhi = round(flo + math.floor((fhi - flo) / step + 1e-9) * step, _digits(step, flo))
    return Dimension(module_id, spec.name, spec, "float", flo, fhi, step, log, none_switch=spec.optional)


def untuned(module: type[Parametrizable] | Parametrizable) -> dict[str, str]:
    """The parameters a module type says no search should change (its ``untuned`` class attribute, name ->
    why), as a dict; unknown names are the conformance check's to report."""
    declared = getattr(module, "untuned", None) or {}
    if isinstance(declared, Mapping):
        return {str(k): str(v) for k, v in declared.items()}
    return {str(name): "the module says so" for name in declared}


def module_dimensions(module_class: type[Parametrizable], module_id: str | None = None) -> list[Dimension]:
    """Every searchable dimension of a module type, in declaration order (``untuned`` and unknown types left
    out); SearchSpaceError at the first declaration the search cannot use."""
    module_id = module_id or module_class.type_name
    skip = untuned(module_class)
    found = []
    for spec in module_class.parameter_specs():
        if spec.name in skip or isinstance(spec, Str):
            continue
        dim = dimension(module_id, spec, module_class.type_name if module_id == module_class.type_name
                        else f"{module_class.type_name} '{module_id}'")
        if dim is not None:
            found.append(dim)
    return found


@dataclass
class SearchSpace:
    """The dimensions of a system's search, and every parameter left out with why (``kept``: key -> reason)."""

    dimensions: list[Dimension]
    kept: dict[str, str]

    @property
    def keys(self) -> list[str]:
        return [d.key for d in self.dimensions]

    def by_module(self) -> dict[str, list[Dimension]]:
        grouped: dict[str, list[Dimension]] = {}
        for dim in self.dimensions:
            grouped.setdefault(dim.module_id, []).append(dim)
        return grouped

    def ordered(self) -> list[Dimension]:
        """Sampling order: the dimensions that always matter first, then the conditional ones, each group in
        declaration order, so relevance is judged on values already drawn."""
        return [d for d in self.dimensions if not d.conditional] + [d for d in self.dimensions if d.conditional]


def split_name(name: str) -> tuple[str, str | None]:
    """``MODULE_ID.PARAMETER`` as (module id, parameter); a bare module id as (id, None)."""
    module_id, _, parameter = name.rpartition(".")
    return (module_id, parameter) if module_id else (name, None)


def _resolve(names: Iterable[str], modules: Sequence[Parametrizable], what: str) -> set[str]:
    """Keys ``MODULE.PARAM`` for each name (a module id alone names all its parameters); SearchSpaceError for
    a name no module has, listing the known ones."""
    by_id = {m.id: m for m in modules}
    keys: set[str] = set()
    for name in names:
        if name in by_id:
            keys.update(f"{name}.{p}" for p in by_id[name].get_parameters())
            continue
        module_id, parameter = split_name(name)
        module = by_id.get(module_id)
        if module is None or parameter not in module.get_parameters():
            known = ", ".join(f"{m.id}.{p}" for m in modules for p in m.get_parameters())
            raise SearchSpaceError(f"{what} {short_repr(name)}: no such module parameter (MODULE_ID.PARAMETER; "
                                   f"known: {known})")
        keys.add(name)
    return keys


def search_space(modules: Sequence[Parametrizable], fix: Iterable[str] = (),
                 search: Iterable[str] | None = None) -> SearchSpace:
    """The search space of a pipeline's modules: every searchable parameter, less those in ``fix`` and, where
    ``search`` is given, only those it names. Names are ``MODULE_ID.PARAMETER`` or a module id alone."""
    fixed = _resolve(fix, modules, "--fix")
    wanted = None if search is None else _resolve(search, modules, "--search")
    dimensions: list[Dimension] = []
    kept: dict[str, str] = {}
    for module in modules:
        skip = untuned(module)
        for spec in module.parameter_specs():
            key = f"{module.id}.{spec.name}"
            if key in fixed:
                kept[key] = "fixed"
            elif wanted is not None and key not in wanted:
                kept[key] = "not searched"
            elif spec.name in skip:
                kept[key] = f"untuned: {skip[spec.name]}"
            elif isinstance(spec, Str):
                kept[key] = "text is not searched"
            else:
                dim = dimension(module.id, spec, module.label)
                if dim is None:
                    kept[key] = f"a {type(spec).__name__} is not searched"
                else:
                    dimensions.append(dim)
    return SearchSpace(dimensions, kept)


def trial_values(space: SearchSpace, start: Mapping[str, Mapping[str, Any]],
                 draw: Any) -> dict[str, dict[str, Any]]:
    """One point of the space as complete values per module id: ``start`` (every module's values) with each
    relevant dimension's value drawn by ``draw(dimension, values_so_far)``; a parameter that does not matter
    given the values drawn keeps its start value, so a point depends on the draws alone."""
    values = {module_id: dict(v) for module_id, v in start.items()}
    for dim in space.ordered():
        current = values[dim.module_id]
        if dim.conditional and not dim.spec.is_relevant(current):
            continue
        current[dim.parameter] = draw(dim, current)
    return values
