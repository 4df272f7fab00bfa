"""Fixtures for the definition GUI's tests: offscreen Qt (tests/conftest.py sets the platform), settings in
a temporary file instead of the user's, and a window that is shown and has displayed a first frame."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("PySide6", reason="the GUI extra (PySide6) is not installed")

from PySide6.QtCore import QSettings

from objrec_apps.gui import DefinitionGUI
from objrec_core import RecognitionSystem


def unexpected_question(question: str) -> Any:
    raise AssertionError(f"the window asked a question the test did not expect: {question!r}")


@pytest.fixture
def settings(tmp_path: Path) -> QSettings:
    return QSettings(str(tmp_path / "objrec-define.ini"), QSettings.Format.IniFormat)


@pytest.fixture
def make_gui(qtbot: Any, settings: QSettings) -> Iterator[Callable[..., DefinitionGUI]]:
    """``make_gui(system, **options)``: a shown DefinitionGUI that has put its first frame on screen."""
    windows: list[DefinitionGUI] = []

    def make(
        system: RecognitionSystem | None = None,
        *,
        wait: bool = True,
        size: tuple[int, int] | None = (1200, 800),
        questions: bool = False,
        **options: Any,
    ) -> DefinitionGUI:
        options.setdefault("settings", settings)
        window = DefinitionGUI(system, **options)
        if not questions:
            # A modal question nobody answers would hang the run: unless the test answers the real dialog
            # (``questions=True``), asking about unsaved changes fails the test at once.
            window.changes.ask = unexpected_question
        # A test's changes are not the user's: closing after the test asks nothing about them.
        qtbot.addWidget(window, before_close_func=lambda w: w.changes.forget())
        windows.append(window)
        if size is not None:  # None keeps the size the settings restored
            window.resize(*size)
        window.show()
        if wait:
            with qtbot.waitSignal(window.frameShown, timeout=HANG_GUARD_MS):
                pass
        return window

    yield make
    for window in windows:
        window.changes.forget()
        window.close()
