"""One conformance check as one test case: a readable id, the check, and a declared deviation if any.

``check_module``, ``check_source`` and ``check_kind`` run every check of a plug-in in turn; ``cases`` gives the
same checks one by one, so a test suite shows each as its own pytest case (``HSVFilter::refusals``,
``wave::seek``) and a failure names the one promise broken. A plug-in that cannot keep one promise, for a
reason, declares it instead of skipping the whole check: ``expected_failures={"seek": "a camera cannot
seek"}`` (an argument, or the class attribute ``expected_failures``). A declared check that fails is
recorded with its reason; one that passes is reported, so stale declarations do not hide regressions.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

log = logging.getLogger(__name__)


@dataclass
class Deviations:
    """What happened to the declared deviations of one run: checks that failed as declared (id: reason and
    the failure), and declared checks that passed all the same."""

    failed_as_declared: dict[str, str] = field(default_factory=dict)
    passed_anyway: list[str] = field(default_factory=list)


def declared_deviations(target: Any, given: Mapping[str, str] | None, check_ids: Iterable[str]) -> dict[str, str]:
    """The deviations a plug-in declares (its class attribute ``expected_failures``) and the caller adds;
    ValueError naming the unknown check ids (a misspelt id must not pass silently) and empty reasons."""
    declared = dict(getattr(target if isinstance(target, type) else type(target), "expected_failures", None) or {})
    declared.update(given or {})
    known = list(check_ids)
    unknown = sorted(set(declared) - set(known))
    if unknown:
        raise ValueError(f"expected_failures names unknown checks {unknown}; the checks are {known}")
    empty = sorted(check for check, reason in declared.items() if not isinstance(reason, str) or not reason.strip())
    if empty:
        raise ValueError(f"expected_failures: give each deviation a reason, not {[declared[c] for c in empty]!r} "
                         f"for {empty}")
    return declared


def run_declared(case_id: str, check: Callable[[], None], reason: str | None, deviations: Deviations) -> bool:
    """Run one check, applying its declared deviation: True when it passed. An undeclared failure raises;
    a declared one is recorded; a declared check that passes is recorded and logged as a warning."""
    if reason is None:
        check()
        return True
    try:
        check()
    except AssertionError as exc:
        deviations.failed_as_declared[case_id] = f"{reason} (failed as declared: {exc})"
        log.info("%s failed as declared (%s): %s", case_id, reason, exc)
        return False
    deviations.passed_anyway.append(case_id)
    log.warning("%s passed although expected_failures declares it fails (%s): remove the declaration",
                case_id, reason)
    return True


@dataclass(frozen=True)
class Case:
    """One check of one plug-in. Calling it runs the check: AssertionError on a broken promise, and on a
    declared deviation that did not happen; ``"deviated"`` when it failed as declared, else ``"passed"``."""

    id: str
    check: Callable[[], None]
    deviation: str | None = None

    def __call__(self) -> str:
        if self.deviation is None:
            self.check()
            return "passed"
        try:
            self.check()
        except AssertionError as exc:
            log.info("%s failed as declared (%s): %s", self.id, self.deviation, exc)
            return "deviated"
        raise AssertionError(f"{self.id}: declared as an expected failure ({self.deviation}) but it passed: "
                             "remove the declaration")

    def __repr__(self) -> str:
        return f"Case({self.id!r})"


def pytest_params(cases: Iterable[Case]) -> list[Any]:
    """``pytest.param`` per case, with its id, for ``@pytest.mark.parametrize("case", ...)``; the test body
    is ``run_case(case)``. pytest is imported here, never when ``objrec_core`` is."""
    import pytest

    return [pytest.param(case, id=case.id) for case in cases]


def run_case(case: Case) -> None:
    """Run a case in a pytest test: a deviation that happened as declared shows as xfail with its reason."""
    if case() == "deviated":
        import pytest

        pytest.xfail(f"declared deviation: {case.deviation}")
