"""Every shipped system, and a 3D pipeline on the real mug scan, fits a 1280x800 laptop
screen and a 1920x1080 one: the window's frame and the parameter panel lie within the screen, the panel
scrolls down rather than sideways, and after a 3D pipeline a 2D one lets the window shrink again.

The windows run in a child process on the offscreen platform given a screen of that size (its
``configfile``); run as a script, this file is that child and prints one JSON line per window.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("PySide6", reason="the GUI extra (PySide6) is not installed")

ROOT = Path(__file__).resolve().parents[2]
MUG = ROOT.parent / "shared" / "data" / "clouds" / "table_scene_mug_stereo_textured.pcd"
#: A hang guard, never a speed limit (seconds).
HANG_GUARD = 240.0


# -- the child ------------------------------------------------------------------------------------------
def _wait_frames(app: Any, gui: Any, count: int) -> int:
    shown = [0]
    gui.frameShown.connect(lambda _shown: shown.__setitem__(0, shown[0] + 1))
    deadline = time.monotonic() + HANG_GUARD
    while shown[0] < count and time.monotonic() < deadline:
        app.processEvents()
        time.sleep(0.005)
    for _ in range(20):  # the layout settles: flows wrap, docks take their size
        app.processEvents()
    return shown[0]


def _figures(gui: Any, name: str, frames: int) -> dict[str, Any]:
    from PySide6.QtCore import QPoint

    dock = gui.panel_dock
    scroll = dock.widget()
    corner = dock.mapToGlobal(QPoint(0, 0))
    screen, frame = gui.screen().availableGeometry(), gui.frameGeometry()
    return {
        "name": name,
        "frames": frames,
        "screen": [screen.x(), screen.y(), screen.width(), screen.height()],
        "frame": [frame.x(), frame.y(), frame.width(), frame.height()],
        "size": list(gui.size().toTuple()),
        "minimum": list(gui.minimumSizeHint().toTuple()),
        "dock": [corner.x(), corner.y(), dock.width(), dock.height()],
        "dock_visible": dock.isVisible(),
        "sideways_scroll": scroll.horizontalScrollBar().maximum(),
        "panels": len(gui.panels.panels),
    }


def child_main() -> int:
    from importlib import resources

    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from objrec_apps.define import SYSTEMS, starting_system
    from objrec_apps.gui import DefinitionGUI

    app = QApplication(sys.argv[:1])
    folder = tempfile.TemporaryDirectory()
    runs = [(name, name, "demo") for name in SYSTEMS]
    if MUG.is_file():
        runs.append(("shape on the mug scan", "shape", str(MUG)))
    for number, (label, system, source) in enumerate(runs):
        settings = QSettings(str(Path(folder.name) / f"settings{number}.ini"), QSettings.Format.IniFormat)
        gui = DefinitionGUI(starting_system(system), settings=settings, source=source)
        gui.show()  # a first run's size (1280 x 800), fitted to the screen
        frames = _wait_frames(app, gui, 3 if source == "demo" else 1)
        print(json.dumps(_figures(gui, label, frames)), flush=True)
        if system == "shape":  # the 3D pipeline replaced by a 2D one: the window shrinks back
            gui.files.load(Path(str(resources.files("objrec_apps") / "systems" / SYSTEMS["hsv"])))
            _wait_frames(app, gui, 2)
            gui.resize(1000, 640)
            _wait_frames(app, gui, 0)
            print(json.dumps(_figures(gui, f"{label}, then hsv, shrunk to 1000x640", 0)), flush=True)
        gui.changes.forget()
        gui.close()
        gui.deleteLater()
        app.processEvents()
    folder.cleanup()
    return 0


# -- the tests ------------------------------------------------------------------------------------------
def run_on_screen(tmp_path: Path, width: int, height: int) -> list[dict[str, Any]]:
    config = tmp_path / "screen.json"
    config.write_text(json.dumps({"screens": [{"name": "laptop", "x": 0, "y": 0, "width": width, "height": height,
                                               "logicalDpi": 96, "logicalBaseDpi": 96, "dpr": 1}]}))
    env = {**os.environ, "QT_QPA_PLATFORM": f"offscreen:configfile={config}", "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
    done = subprocess.run([sys.executable, __file__], capture_output=True, text=True, env=env, cwd=ROOT,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def inside(inner: list[int], outer: list[int]) -> bool:
    x, y, w, h = inner
    ox, oy, ow, oh = outer
    return ox <= x and oy <= y and x + w <= ox + ow and y + h <= oy + oh


@pytest.mark.parametrize(("width", "height"), [(1280, 800), (1920, 1080)])
def test_every_shipped_system_fits_the_screen_and_the_window_shrinks_back(tmp_path, width, height):
    windows = run_on_screen(tmp_path, width, height)
    names = [w["name"] for w in windows]
    assert names[:3] == ["hsv", "feature", "shape"], names
    assert "shape, then hsv, shrunk to 1000x640" in names
    for window in windows:
        print(window)
        where = f"{window['name']} at {width}x{height}: {window}"
        assert window["screen"] == [0, 0, width, height], where
        if not window["name"].endswith("1000x640"):
            assert window["frames"] >= 1, where  # measured with the pipeline's results on screen
        assert inside(window["frame"], window["screen"]), where
        assert window["dock_visible"] and inside(window["dock"], window["screen"]), where
        assert window["dock"][2] >= 300, where  # the parameters are readable, not squeezed
        assert window["sideways_scroll"] == 0, where  # the panels wrap: the dock scrolls down, never sideways
        # room to spare on a 1280 px laptop for the window manager's frame and a side panel
        assert window["minimum"][0] <= 1100 and window["minimum"][1] <= 700, where
    for window in windows:
        if window["name"].endswith("1000x640"):
            assert window["size"] == [1000, 640], window  # after a 3D pipeline, a 2D one shrinks back
    if not MUG.is_file():
        pytest.skip(f"the mug scan is not at {MUG}: the 3D pipeline on real data was not measured")
    assert "shape on the mug scan" in names


def test_a_flow_of_controls_wraps_instead_of_widening(qtbot):
    from PySide6.QtWidgets import QPushButton, QWidget

    from objrec_apps.gui.flow_layout import FlowLayout

    holder = QWidget()
    qtbot.addWidget(holder)
    flow = FlowLayout(holder)
    buttons = [QPushButton(f"control number {i}") for i in range(8)]
    for button in buttons:
        flow.addWidget(button)
    widest = max(b.sizeHint().width() for b in buttons)
    margins = flow.contentsMargins()
    assert flow.minimumSize().width() == widest + margins.left() + margins.right()  # one control, not eight
    one_row, narrow = flow.heightForWidth(10_000), flow.heightForWidth(widest + 20)
    assert narrow >= 7 * one_row  # one control a row
    holder.resize(widest + 20, narrow)
    holder.show()
    qtbot.waitUntil(lambda: buttons[-1].y() > buttons[0].y())
    assert all(b.geometry().right() <= holder.width() for b in buttons)


def test_a_window_larger_than_the_screen_is_brought_back_within_it(qtbot):
    from PySide6.QtCore import QRect
    from PySide6.QtWidgets import QWidget

    from objrec_apps.gui.window_fit import fit_to_screen

    window = QWidget()
    qtbot.addWidget(window)
    window.setMinimumSize(500, 400)
    window.setGeometry(300, 200, 1650, 1000)
    laptop = QRect(0, 0, 1280, 800)
    assert fit_to_screen(window, laptop)
    assert laptop.contains(window.frameGeometry()) and window.width() <= 1280
    assert not fit_to_screen(window, laptop)  # inside: left alone
    window.setGeometry(0, 0, 400, 300)
    fit_to_screen(window, QRect(0, 0, 300, 200))
    assert window.width() >= 500 and window.height() >= 400  # never below its minimum size


def test_the_hidden_3d_page_does_not_set_a_2d_window_s_minimum(make_gui):
    from objrec_apps.define import starting_system

    gui = make_gui(starting_system("hsv"))
    gui.view3d.controls.setMinimumWidth(3000)  # however wide the 3D page's controls were
    gui.central.updateGeometry()
    assert gui.central.currentWidget() is gui.stage_views
    assert gui.central.minimumSizeHint() == gui.stage_views.minimumSizeHint()
    assert gui.minimumSizeHint().width() < 1280


if __name__ == "__main__":
    code = child_main()
    sys.stdout.flush()
    # The figures are out: skip the interpreter's teardown, which at the time of writing crashes in
    # QMenuBar::eventFilter while PySide destroys the leftover widgets (another part of the window; reported).
    os._exit(code)
