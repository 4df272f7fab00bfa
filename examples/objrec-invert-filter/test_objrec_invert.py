"""The example plug-in's own tests: its behaviour in numbers, and ``check_module`` on its filter.

Run from the repository: ``python -m pytest examples/objrec-invert-filter``; the project's suite runs them
too (tests/core/test_core_plugins.py).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from objrec_core.testing import cases, check_module, pytest_params, run_case

HERE = Path(__file__).resolve().parent


def load_example() -> ModuleType:
    """objrec_invert from beside this file, whether or not the package is installed."""
    spec = importlib.util.spec_from_file_location("objrec_invert", HERE / "objrec_invert.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_invert_filter_in_numbers():
    invert = load_example().InvertFilter()
    image = np.array([[[0, 0, 0], [255, 255, 255]], [[40, 40, 40], [100, 100, 100]]], dtype=np.uint8)
    assert invert.filter(image).tolist() == [[255, 0], [215, 155]]  # grey, then 255 - value
    invert.set_parameters(threshold=60)
    assert invert.filter(image).tolist() == [[255, 0], [255, 0]]  # at or below 60 white, the rest black
    invert.set_parameters(grey=False, threshold=0)
    assert invert.filter(image).shape == (2, 2, 3)  # colour stays colour


def test_invert_filter_conforms():
    """Bounds, types, boundary values on demo frames, the input left alone, the parameter-file round trip,
    repr, snapshots across threads and change events."""
    report = check_module(load_example().InvertFilter)
    assert report.refused >= 15 and report.boundaries == 4 and report.frames >= 6


@pytest.mark.parametrize("case", pytest_params(cases(load_example().InvertFilter)))
def test_invert_filter_case(case):
    """The same checks one by one, each its own pytest case (``InvertFilter::boundaries``), as a plug-in's
    suite lists them: a failure names the promise broken."""
    run_case(case)
