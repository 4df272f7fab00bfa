"""A new user's walk-through of objrec-define on a real X server, with a screenshot at every step and a list of
what looks wrong in each (a control outside the window or clipped, a label's text cut, two controls on top of
each other), on stdout as one JSON line per screenshot. Anything on stderr is a finding too.

    xvfb-run -a -s "-screen 0 1920x1080x24" env QT_QPA_PLATFORM=xcb .venv/bin/python scripts/walkthrough.py OUT \
        [--only STEP] [--prefix walk-]

Steps (``--only`` picks some): every shipped system and the empty window on the demo, each at 1920x1080, then
1280x800 (a common laptop), then 1920x1080 again; the shipped shape system on the real mug scan turned with the
mouse and a 3D parameter changed; a video paused, sought far (past what a truncated file decodes) and near,
looped, played to its end and restarted; the HSV eyedropper dragged loosely round a blue candy on smarties.png. The data
outside the repository (``../shared/data``) is skipped where absent.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import screenshots as shots  # the screenshot script's helpers, from this folder
from PySide6.QtCore import QEvent, QPoint, QPointF, QRect, QSettings, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import (
    QAbstractButton,
    QAbstractScrollArea,
    QAbstractSpinBox,
    QApplication,
    QComboBox,
    QLabel,
    QLineEdit,
    QSlider,
    QTabBar,
    QToolBar,
    QWidget,
)

from objrec_apps.define import SYSTEMS, starting_system
from objrec_apps.gui import DefinitionGUI

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
VIDEO = DATA / "images" / "tree.avi"
SMARTIES = DATA / "images" / "smarties.png"
#: The loosely picked blue candy of smarties.png (its labelled box, x, y, width, height) and the slack round it.
BLUE_CANDY, SLACK = (351, 55, 52, 53), 10
#: The widgets a user reads or clicks, checked one by one.
CONTROLS = (QLabel, QAbstractButton, QAbstractSpinBox, QComboBox, QLineEdit, QSlider)


def scrolled(widget: QWidget) -> bool:
    """Inside a scroll area (the parameter dock, a table): cut off by scrolling on purpose."""
    parent = widget.parentWidget()
    while parent is not None:
        if isinstance(parent, QAbstractScrollArea) and not isinstance(parent, QLineEdit):
            return True
        parent = parent.parentWidget()
    return False


def describe(widget: QWidget) -> str:
    text = widget.text() if hasattr(widget, "text") else ""
    return f"{type(widget).__name__}({widget.objectName() or str(text)[:30]!r})"


def findings(gui: DefinitionGUI) -> list[str]:
    """What a user would see as broken in the window as it is now."""
    found = []
    window = gui.rect()
    controls = [w for w in gui.findChildren(QWidget) if isinstance(w, CONTROLS) and w.isVisible() and w.width() > 0]
    for widget in controls:
        where = QRect(widget.mapTo(gui, QPoint(0, 0)), widget.size())
        if scrolled(widget):
            continue
        if not window.contains(where):
            found.append(f"outside the window: {describe(widget)} at {where.getRect()}")
        seen = widget.visibleRegion().boundingRect()
        in_toolbar = isinstance(widget.parentWidget(), QToolBar)  # a toolbar's overflow menu has the rest
        if not in_toolbar and 0 < seen.width() < widget.width() - 2:
            found.append(f"clipped: {describe(widget)} shows {seen.width()} of {widget.width()} px")
        if (isinstance(widget, QLabel) and not widget.wordWrap() and widget.text()
                and widget.sizeHint().width() > widget.width() + 2):
            found.append(f"text cut: {describe(widget)} needs {widget.sizeHint().width()} px, has {widget.width()}")
        if (isinstance(widget, QAbstractButton) and widget.text() and not isinstance(widget.parentWidget(), QTabBar)
                and widget.sizeHint().width() > widget.width() + 2):
            found.append(f"squeezed: {describe(widget)} needs {widget.sizeHint().width()} px, has {widget.width()}")
    siblings: dict[int, list[QWidget]] = {}
    for widget in controls:
        siblings.setdefault(id(widget.parentWidget()), []).append(widget)
    for group in siblings.values():
        for i, a in enumerate(group):
            for b in group[i + 1:]:
                overlap = a.geometry().intersected(b.geometry())
                if overlap.width() > 2 and overlap.height() > 2:
                    found.append(f"overlap: {describe(a)} and {describe(b)}")
    return found


class Walk:
    """One walk-through: its application, settings and the folder the screenshots go to."""

    def __init__(self, app: QApplication, settings: QSettings, out: Path, prefix: str) -> None:
        self.app, self.settings, self.out, self.prefix = app, settings, out, prefix

    def shot(self, gui: DefinitionGUI, name: str, facts: Callable[[], dict[str, Any]] = dict) -> None:
        """A screenshot once the window has settled, and its facts (``facts()``, read then) and findings."""
        shots.settle(self.app, 0.5)
        gui.grab().save(str(self.out / f"{self.prefix}{name}.png"))
        print(json.dumps({"name": name, "size": list(gui.size().toTuple()), "minimum": list(
            gui.minimumSizeHint().toTuple()), **facts(), "findings": findings(gui)}), flush=True)

    def sizes(self, gui: DefinitionGUI, name: str) -> None:
        for size, label in (((1920, 1080), "1920"), ((1280, 800), "1280"), ((1920, 1080), "back1920")):
            gui.resize(*size)
            self.shot(gui, f"{name}-{label}")

    def system(self, name: str) -> None:
        gui = shots.window(starting_system(name), self.settings, "grid")
        shots.step_to(self.app, gui, 3)
        self.sizes(gui, name)
        shots.close(gui)

    def empty(self) -> None:
        gui = shots.window(None, self.settings, "grid")
        self.sizes(gui, "empty")
        shots.close(gui)

    def mug(self) -> None:
        if not shots.MUG.is_file():
            print(f"skipped the mug scan: {shots.MUG} is absent", file=sys.stderr)
            return
        gui = shots.window(starting_system("shape"), self.settings, "grid", source=str(shots.MUG))
        shots.step_to(self.app, gui, 0)
        shots.wait_until(self.app, lambda: gui.view3d.full_results_shown >= 1, timeout=180)
        self.shot(gui, "mug-1280")
        view = gui.view3d.cloud_view
        left, none = Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton
        centre = QPointF(view.width() / 2, view.height() / 2)

        def mouse(kind: QEvent.Type, pos: QPointF, buttons: Qt.MouseButton, button: Qt.MouseButton) -> None:
            QApplication.sendEvent(view, QMouseEvent(kind, pos, QPointF(view.mapToGlobal(pos.toPoint())), button,
                                                     buttons, Qt.KeyboardModifier.NoModifier))

        mouse(QEvent.Type.MouseButtonPress, centre, left, left)
        for step in range(1, 30):  # a drag of a second or so: the view turns, thinned while it moves
            mouse(QEvent.Type.MouseMove, centre + QPointF(6 * step, 2 * step), left, none)
            self.app.processEvents()
            time.sleep(0.02)
        self.shot(gui, "mug-turning", lambda: {"moving": view.moving})
        mouse(QEvent.Type.MouseButtonRelease, centre + QPointF(180, 60), none, left)
        shots.settle(self.app, 1.0)
        self.shot(gui, "mug-turned")
        shown = gui.view3d.full_results_shown
        gui.system.module("cylinder").set_parameters(min_radius=0.03)
        shots.wait_until(self.app, lambda: gui.view3d.full_results_shown > shown, timeout=180)
        self.shot(gui, "mug-tuned", lambda: {"previews": gui.view3d.previews_shown})
        shots.close(gui)

    def video(self) -> None:
        if not VIDEO.is_file():
            print(f"skipped the video: {VIDEO} is absent", file=sys.stderr)
            return
        gui = shots.window(starting_system("hsv"), self.settings, "grid", source=str(VIDEO))
        shots.step_to(self.app, gui, 0)
        self.shot(gui, "video-first")
        gui.source_bar.pause_action.trigger()  # Resume
        shots.settle(self.app, 1.5)
        self.shot(gui, "video-playing")
        gui.source_bar.pause_action.trigger()  # Pause
        self.shot(gui, "video-paused")
        slider = gui.seek_bar.slider
        slider.setValue(slider.maximum() // 2)  # far: past what this truncated file decodes
        shots.settle(self.app, 3.0)
        self.shot(gui, "video-seek-far", lambda: {"counter": gui.seek_bar.counter_text})
        slider.setValue(30)
        shots.wait_until(self.app, lambda: gui.last_results.frame.index == 30, timeout=60)
        self.shot(gui, "video-seeked", lambda: {"counter": gui.seek_bar.counter_text})
        gui.seek_bar.loop_box.setChecked(True)
        slider.setValue(200)
        shots.wait_until(self.app, lambda: gui.last_results.frame.index == 200, timeout=60)
        gui.source_bar.pause_action.trigger()  # plays on into the broken frames: Loop starts it again
        shots.wait_until(self.app, lambda: gui.last_results.frame.index < 10, timeout=60)
        self.shot(gui, "video-looped")
        gui.seek_bar.loop_box.setChecked(False)
        shots.wait_until(self.app, lambda: gui.worker.ended, timeout=120)
        bar = gui.source_bar
        self.shot(gui, "video-ended", lambda: {"counter": gui.seek_bar.counter_text,
                                               "rates": bar.fps_label.text().strip(),
                                               "source": bar.name_label.text().strip(),
                                               "button": bar.pause_action.text(),
                                               "status": gui.statusBar().currentMessage()})
        bar.pause_action.trigger()  # Restart: from the first frame again
        shots.wait_until(self.app, lambda: not bar.ended and gui.last_results.frame.index >= 5, timeout=60)
        self.shot(gui, "video-restarted", lambda: {"counter": gui.seek_bar.counter_text,
                                                   "button": bar.pause_action.text()})
        shots.close(gui)

    def smarties(self) -> None:
        if not SMARTIES.is_file():
            print(f"skipped the eyedropper: {SMARTIES} is absent", file=sys.stderr)
            return
        system = starting_system("hsv")
        system.module("colour").reset_parameters()  # pass-everything: the eyedropper sets the ranges
        gui = shots.window(system, self.settings, "grid", source=str(SMARTIES))
        shots.step_to(self.app, gui, 0)
        view = gui.stage_views.view("input")
        x, y, w, h = BLUE_CANDY
        generation = gui.worker.generation
        shots.drag(view, view.to_widget(QPointF(x - SLACK, y - SLACK)),
                   view.to_widget(QPointF(x + w + SLACK, y + h + SLACK)), Qt.KeyboardModifier.ShiftModifier)
        shots.wait_until(self.app, lambda: gui.last_shown_generation > generation)
        self.shot(gui, "smarties-blue", lambda: {"colour": gui.system.module("colour").get_parameters(),
                                                 "found": len(gui.last_results.objects.objects)})
        shots.close(gui)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="the folder the screenshots go to")
    steps = [*SYSTEMS, "empty", "mug", "video", "smarties"]
    parser.add_argument("--only", action="append", choices=steps)
    parser.add_argument("--prefix", default="walk-", help="the start of every screenshot's file name")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    with tempfile.TemporaryDirectory() as folder:
        settings = QSettings(str(Path(folder) / "settings.ini"), QSettings.Format.IniFormat)
        walk = Walk(app, settings, args.out, args.prefix)
        runs: dict[str, Callable[[], None]] = {name: (lambda n=name: walk.system(n)) for name in SYSTEMS}
        runs |= {"empty": walk.empty, "mug": walk.mug, "video": walk.video, "smarties": walk.smarties}
        for name in args.only or steps:
            runs[name]()
            settings.clear()
    sys.stdout.flush()
    os._exit(0)  # as tests/gui/test_gui_laptop.py: PySide's teardown of the leftover widgets can crash


if __name__ == "__main__":
    sys.exit(main())
