"""Quit then Discard ends without a traceback; the Edit menu names the value a
slider drag ended on; Ctrl+Z undoes while a spin box has the keyboard focus."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from PySide6.QtCore import Qt
from PySide6.QtTest import QTest

from objrec_apps.define import starting_system
from tests.qt_waits import HANG_GUARD_MS

PROJECT = Path(__file__).resolve().parents[2]

QUIT_THEN_DISCARD = textwrap.dedent("""
    import sys
    import shiboken6
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication
    app = QApplication([])
    from objrec_apps.define import starting_system
    from objrec_apps.gui import DefinitionGUI
    from objrec_apps.gui.changes import Answer
    window = DefinitionGUI(starting_system("hsv"), settings=QSettings(sys.argv[1], QSettings.Format.IniFormat),
                           paused=True)
    window.show()
    window.system.module("colour").set_parameters(h_min=5)  # an unsaved change
    app.processEvents()
    asked = []
    window.changes.ask = lambda question: asked.append(question) or Answer.DISCARD
    if sys.argv[2] == "quit":
        window.quit_action.trigger()
        assert asked and not window.isVisible(), asked
    shiboken6.delete(window)  # what the end of objrec-define's run() does to the window
    print("ended", flush=True)
""")


@pytest.mark.timeout(180)
@pytest.mark.parametrize("how", ["quit", "without closing"])
def test_quit_then_discard_prints_no_traceback(tmp_path, how):
    """The undo stack, still holding the discarded steps, clears itself while it is destroyed and says the
    window is clean: the window used to ask the dying stack for its state and print a traceback."""
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", PYTHONPATH=str(PROJECT))
    done = subprocess.run([sys.executable, "-c", QUIT_THEN_DISCARD, str(tmp_path / "settings.ini"), how],
                          capture_output=True, text=True, env=env, cwd=PROJECT, timeout=170)
    assert done.returncode == 0, done.stderr
    assert "ended" in done.stdout
    assert "Traceback" not in done.stderr and "already deleted" not in done.stderr, done.stderr


def hsv_window(make_gui):
    return make_gui(starting_system("hsv"), paused=True, wait=False)


def test_the_undo_menu_names_the_value_a_drag_ended_on(make_gui):
    gui = hsv_window(make_gui)
    editor = gui.panels.panel("colour").editors["h_min"]
    slider = editor.slider
    slider.setSliderDown(True)
    for value in (6, 20, 55, 87):  # the throttle sends the first at once, then the rest as they come
        slider.setValue(editor.position_of(value))
    slider.setSliderDown(False)
    assert gui.system.module("colour").h_min == 87
    assert gui.undo.stack.count() == 1
    assert gui.undo.stack.text(0) == "colour.h_min = 87"
    assert gui.undo_action.text().endswith("colour.h_min = 87")


@pytest.mark.timeout(120)
def test_ctrl_z_undoes_while_a_spin_box_has_the_focus(make_gui, qtbot):
    gui = hsv_window(make_gui)
    colour = gui.system.module("colour")
    editor = gui.panels.panel("colour").editors["s_min"]
    gui.activateWindow()
    editor.spin.setFocus(Qt.FocusReason.MouseFocusReason)
    qtbot.waitUntil(lambda: editor.spin.hasFocus(), timeout=HANG_GUARD_MS)
    before = colour.s_min
    QTest.keyClick(editor.spin, Qt.Key.Key_Up)  # one step up, applied at once
    assert colour.s_min == before + 1 and gui.undo.stack.count() == 1
    QTest.keyClick(editor.spin, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert colour.s_min == before and editor.spin.value() == before
    QTest.keyClick(editor.spin, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    assert colour.s_min == before + 1
