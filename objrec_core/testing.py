"""Conformance checks for plug-ins, as scikit-learn's ``check_estimator`` is for estimators: the public home of
``check_module``, ``check_source``, ``check_kind`` and their per-case form.

A module's declarations are promises (what is refused, what a panel offers, what a file keeps), and so are a
source's and a kind's contracts. ``check_module(ModuleClass)``, ``check_source(SourceClass, spec=...)`` and
``check_kind(kind)`` hold a plug-in to all of them, the same way as the built-in ones::

    from objrec_core.testing import check_module

    def test_my_filter():
        check_module(MyFilter)

The first broken promise raises AssertionError naming the plug-in, the check, the parameter and the value.
``cases(plugin)`` gives each check as its own case with a readable id (``MyFilter::boundaries``), for
``@pytest.mark.parametrize("case", pytest_params(cases(MyFilter)))`` and ``run_case(case)``; a plug-in declares
a check it cannot pass, with the reason, in ``expected_failures``. The code lives in
:mod:`objrec_core.conformance`, one module per job (module, source and kind checks, cases and deviations, CPU
time limits, demo frames); pytest is imported only when ``pytest_params`` or ``run_case`` is called.
"""

from __future__ import annotations

# The public names are conformance's own, re-exported whole: one list, kept in objrec_core.conformance.
from .conformance import *  # noqa: F403
from .conformance import __all__  # noqa: F401
