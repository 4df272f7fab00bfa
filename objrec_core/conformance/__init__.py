"""Conformance checks for plug-ins: module types, source types and data kinds, each held to its contract.

``check_module``, ``check_source`` and ``check_kind`` run every check of one plug-in and raise AssertionError
at the first broken promise, naming the plug-in, the check and the value. ``cases`` gives the same checks one
by one with readable ids, so a test suite runs each as its own pytest case::

    import pytest
    from objrec_core.testing import cases, pytest_params, run_case

    @pytest.mark.parametrize("case", pytest_params([*cases(MyFilter), *cases(MySource, spec="my:frames=3")]))
    def test_conformance(case):
        run_case(case)

``objrec_core.testing`` is the public home of these names; this package holds one module per job.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..kinds import Kind
from ..modules import Detector, Filter
from ..sources import FrameSource
from .cases import Case, Deviations, pytest_params, run_case
from .kind_checks import KIND_CHECKS, KindReport, check_kind, kind_cases
from .limits import CPULimitExceeded, call_with_cpu_limit
from .module_checks import MODULE_CHECK_IDS, CheckReport, check_all_modules, check_module, module_cases
from .source_checks import SOURCE_CHECKS, SourceReport, check_source, source_cases

__all__ = [
    "KIND_CHECKS",
    "MODULE_CHECK_IDS",
    "SOURCE_CHECKS",
    "CPULimitExceeded",
    "Case",
    "CheckReport",
    "Deviations",
    "KindReport",
    "SourceReport",
    "call_with_cpu_limit",
    "cases",
    "check_all_modules",
    "check_kind",
    "check_module",
    "check_source",
    "kind_cases",
    "module_cases",
    "pytest_params",
    "run_case",
    "source_cases",
]


def cases(target: Any, *, expected_failures: Mapping[str, str] | None = None, **options: Any) -> list[Case]:
    """The checks of one plug-in as separate cases, whatever it is: a Filter or Detector subclass (options of
    ``check_module``), a FrameSource subclass or a source spec (options of ``check_source``), or a Kind, its
    class (options of ``check_kind``)."""
    if isinstance(target, type) and issubclass(target, Filter | Detector):
        return module_cases(target, expected_failures=expected_failures, **options)
    if isinstance(target, str) or (isinstance(target, type) and issubclass(target, FrameSource)):
        return source_cases(target, expected_failures=expected_failures, **options)
    if isinstance(target, Kind) or (isinstance(target, type) and issubclass(target, Kind)):
        return kind_cases(target, expected_failures=expected_failures, **options)
    raise TypeError(f"{target!r} is no module type, source type, source spec or kind")
