"""What the module checks compare and set up with: values as a file keeps them (a float that comes back as an
int is a change, NaN equals NaN), an observer that records, the module type in the registry for a file's
round trip, and frequent thread switches so a half-done update has a chance of being seen."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import yaml

from declare.parameters import same_value as same
from declare.parameters import short_repr

from ..observer import Change
from ..parametrizable import Parametrizable
from ..registry import MODULES


def same_values(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)


def differences(a: Mapping[str, Any], b: Mapping[str, Any]) -> str:
    names = sorted(set(a) | set(b))
    diffs = [f"{n}: {short_repr(a.get(n, '<missing>'))} -> {short_repr(b.get(n, '<missing>'))}"
             for n in names if n not in a or n not in b or not same(a[n], b[n])]
    return "; ".join(diffs)


def as_file_data(value: Any) -> Any:
    """What a value becomes after a trip through YAML (tuples become lists): what a file can keep."""
    return yaml.safe_load(yaml.safe_dump(value, sort_keys=True))


class Recorder:
    """An observer that keeps every notification."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, tuple[Change, ...]]] = []

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        self.calls.append((subject, tuple(changes)))


@contextlib.contextmanager
def registered(module_class: type[Parametrizable]) -> Iterator[None]:
    """The module type in the registry for the duration (a file names modules by registered type): the
    registry's one sanctioned way to shadow an installed type of the same name, undone afterwards."""
    with MODULES.replaced(module_class.type_name, module_class):
        yield


@contextlib.contextmanager
def switch_interval(seconds: float) -> Iterator[None]:
    """Switch threads often, so a half-done update has a real chance of being seen."""
    before = sys.getswitchinterval()
    sys.setswitchinterval(seconds)
    try:
        yield
    finally:
        sys.setswitchinterval(before)


class NamedChecks:
    """A checker whose checks are methods ``check_<id>`` (``rate-stamp`` -> ``check_rate_stamp``): each is run
    by its id, alone or in a sequence, and recorded in the report's ``checks`` when it passes."""

    check: str
    report: Any

    def runner(self, check: str) -> Callable[[], None]:
        method = getattr(self, "check_" + check.replace("-", "_"))

        def run() -> None:
            self.check = check
            method()
            self.report.checks.append(check)

        return run
