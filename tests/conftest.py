"""Shared fixtures: where the real data lives, the Qt platform for headless runs, and Ctrl-C as a terminal
sends it."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

# The tests press Ctrl-C as a person at a terminal does. A suite started in the background of a script
# (`bash run &`) inherits Ctrl-C ignored, which the commands rightly keep ignoring (strictio.signals), so
# every command the tests start would too: take Python's own handling back, which the children then get.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

PROJECT_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("OBJREC_SHARED_DATA", PROJECT_ROOT.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real images, clouds and maps made by others; tests using it skip where it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real test data not found at {SHARED_DATA} (set OBJREC_SHARED_DATA)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def project_root() -> Path:
    return PROJECT_ROOT
