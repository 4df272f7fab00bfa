"""Fixtures of the ROS tests: the bag writer (``bagmaker``) and the demo frames the recordings are made of.

Tests run with ``--import-mode=importlib``, which puts no test folder on ``sys.path``; ``bagmaker.py`` is
loaded here by path (once, under the module name ``objrec_tests_bagmaker``) and handed out as a fixture.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")

_BAGMAKER = "objrec_tests_bagmaker"


def load_bagmaker() -> ModuleType:
    """``tests/ros/bagmaker.py`` as a module (the same one on every call)."""
    if _BAGMAKER in sys.modules:
        return sys.modules[_BAGMAKER]
    spec = importlib.util.spec_from_file_location(_BAGMAKER, Path(__file__).with_name("bagmaker.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[_BAGMAKER] = module  # before executing: its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def bagmaker() -> ModuleType:
    """The test recordings' writer: ``Messages(fmt)`` builds messages, ``write(base, fmt, maker, entries)``."""
    return load_bagmaker()


@pytest.fixture(scope="session")
def demo_images() -> list:
    """Three frames of the 2D demo scene (BGR uint8, 640 x 480)."""
    from objrec_core import open_source

    with open_source("demo:frames=3", "2d") as source:
        return [frame.data for frame in source]


@pytest.fixture(scope="session")
def demo_clouds() -> list:
    """Two frames of the 3D demo scene (organized 640 x 480, coloured, NaN where no return)."""
    from objrec_core import open_source

    with open_source("demo:frames=2", "3d") as source:
        return [frame.data for frame in source]
