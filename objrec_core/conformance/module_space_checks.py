"""The conformance check of a module's search space: its declarations make a space a tuning search can use.

``objrec-tune`` searches what the declarations allow (:mod:`objrec_core.tuning.space`), so a plug-in module is
tunable with no extra code, provided its declarations say enough. This check holds every module type to it:

- every parameter the search would try has finite bounds (soft or hard) or choices; one that has none is
  either bounded or listed in the module's ``untuned`` (name -> why), and ``untuned`` names only declared
  parameters;
- each end of every dimension, and points drawn at random from the whole space, pass the declarations'
  validation; a point that breaks a rule between parameters is refused with a ParameterError (the search then
  scores it 0), never another exception;
- fixing every parameter leaves nothing to search and the module at its values, which its rules accept.

Optuna is not needed: points are drawn with Python's ``random``, seeded, so the check is the same every run.
"""

from __future__ import annotations

import random
from typing import Any, Protocol

from declare.parameters import ParameterError, short_repr

from ..parametrizable import Parametrizable
from ..tuning.space import SearchSpaceError, module_dimensions, search_space, untuned

#: Random points of the space tried per module type.
SPACE_POINTS = 50
#: Seed of the points' draws.
SPACE_SEED = 23


class SpaceChecker(Protocol):
    """What the check needs of ``module_checks._Checker``."""

    cls: type[Parametrizable]

    def begin(self, check: str) -> None: ...

    def fail(self, problem: str, parameter: str | None = None, value: Any = None, *, cause: Any = None) -> None: ...

    def make(self) -> Parametrizable: ...


def check_search_space(checker: SpaceChecker) -> None:
    """The ``search-space`` check of ``check_module``: see the module docstring."""
    checker.begin("search space")
    cls = checker.cls
    declared = {spec.name for spec in cls.parameter_specs()}
    for name in untuned(cls):
        if name not in declared:
            checker.fail(f"untuned names {name!r}, which is no declared parameter")
    try:
        dimensions = module_dimensions(cls)
    except SearchSpaceError as exc:
        checker.fail(str(exc), cause=exc)
        raise  # unreachable: fail raised
    module = checker.make()
    defaults = module.get_parameters()
    for dim in dimensions:
        for value in dim.ends():
            _expect_valid(checker, module, dim.parameter, value, "an end of its search range")
    rng = random.Random(SPACE_SEED)
    for _ in range(SPACE_POINTS):
        point = {dim.parameter: dim.sample(rng) for dim in dimensions}
        for name, value in point.items():
            _expect_valid(checker, module, name, value, "a value drawn from its search range")
        try:
            module.set_parameters(**{**defaults, **point})
        except ParameterError:
            pass  # a rule between parameters refused the point: the search scores it 0 and moves on
        except Exception as exc:
            checker.fail(f"a point of the search space raised {type(exc).__name__} instead of ParameterError: {exc}"
                         f" ({_shown(point)})", cause=exc)
    module.set_parameters(**defaults)
    everything = [f"{module.id}.{name}" for name in declared]
    left = search_space([module], fix=everything)
    if left.dimensions:
        checker.fail(f"fixing every parameter still leaves {left.keys} to search")
    if module.get_parameters() != defaults:
        checker.fail("building its search space changed the module's values")
    try:
        module.check_values(defaults)
    except ParameterError as exc:
        checker.fail(f"its own defaults break a rule: {exc}", cause=exc)


def _expect_valid(checker: SpaceChecker, module: Parametrizable, name: str, value: Any, what: str) -> None:
    try:
        module.validate_parameters({name: value})
    except ParameterError as exc:
        checker.fail(f"{what} is refused by its own declaration: {exc}", name, value, cause=exc)


def _shown(point: dict[str, Any]) -> str:
    return ", ".join(f"{k}={short_repr(v)}" for k, v in point.items())
