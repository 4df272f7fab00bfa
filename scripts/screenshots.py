"""Regenerate the screenshots of the definition GUI on the demo sources, into docs/images/.

    xvfb-run -a -s "-screen 0 1280x800x24" env QT_QPA_PLATFORM=xcb .venv/bin/python scripts/screenshots.py
    QT_QPA_PLATFORM=offscreen .venv/bin/python scripts/screenshots.py [--out docs/images] [--only NAME]

Every picture is made the way a user would get there (Pipeline menu, panels, a mouse selection), paused on
fixed demo frames so the pictures are the same on every run. The window is 1280x800, a common laptop's
screen: what the pictures show fits there. They are saved as 256-colour PNGs where Pillow is
installed (a third of the size).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6.QtCore import QEvent, QPointF, QSettings, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication

from objrec_apps.define import starting_system
from objrec_apps.gui import DefinitionGUI
from objrec_core import RecognitionSystem, Rect, open_source

SIZE = (1280, 800)
#: The real scan (PCL's cylinder tutorial; /work/shared/data/README.md), not shipped with objrec.
MUG = Path(__file__).resolve().parents[2] / "shared" / "data" / "clouds" / "table_scene_mug_stereo_textured.pcd"


def wait_until(app: QApplication, condition: Callable[[], bool], timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError("the window did not get there in time")
        app.processEvents()
        time.sleep(0.005)


def settle(app: QApplication, seconds: float = 0.3) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        time.sleep(0.01)


def step_to(app: QApplication, gui: DefinitionGUI, index: int) -> None:
    """Single-step until frame ``index`` is on screen."""
    while gui.last_results is None or gui.last_results.frame.index < index:
        shown_before = gui.last_results.frame.index if gui.last_results else -1
        gui.worker.step()
        wait_until(app, lambda s=shown_before: gui.last_results is not None and gui.last_results.frame.index > s)


def hover(gui: DefinitionGUI, key: str, name: str) -> None:
    """Put the mouse on the demo object ``name`` in the view ``key`` (its pixel readout shows)."""
    x, y = next(o["centroid"] for o in gui.last_results.frame.truth["objects"] if o["name"] == name)
    view = gui.stage_views.view(key)
    pos = view.to_widget(QPointF(x + 0.5, y + 0.5))
    event = QMouseEvent(QEvent.Type.MouseMove, pos, QPointF(view.mapToGlobal(pos.toPoint())),
                        Qt.MouseButton.NoButton, Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier)
    QApplication.sendEvent(view, event)


def window(system: RecognitionSystem | None, settings: QSettings, mode: str, source: object = "demo") -> DefinitionGUI:
    gui = DefinitionGUI(system, source=source, settings=settings, view_mode=mode, paused=True)
    gui.resize(*SIZE)
    gui.show()
    return gui


def close(gui: DefinitionGUI) -> None:
    """Close without the unsaved-changes question: the tuning here was for the picture only."""
    gui.changes.forget()
    gui.close()


def save(app: QApplication, gui: DefinitionGUI, path: Path, wait: bool = True) -> None:
    """The window as a PNG (256 colours where Pillow is installed); ``wait`` lets it settle first."""
    if wait:
        settle(app)
    gui.grab().save(str(path))
    try:
        from PIL import Image
    except ImportError:
        print(f"wrote {path} (Pillow is not installed: all colours)")
        return
    with Image.open(path) as picture:
        few = picture.convert("RGB").quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    few.save(path, optimize=True)
    print(f"wrote {path}")


def empty_window(app: QApplication, settings: QSettings, out: Path) -> None:
    gui = window(None, settings, "grid")
    settle(app)
    gui.pipeline_menu.populate()
    save(app, gui, out / "define_empty.png")
    close(gui)


def hsv(app: QApplication, settings: QSettings, out: Path) -> None:
    gui = window(starting_system("hsv"), settings, "grid")
    step_to(app, gui, 40)
    hover(gui, "input", "red")  # on the red disk: its BGR and HSV show in the status bar
    save(app, gui, out / "define_hsv.png")
    gui.system.module("colour").set_parameters(h_min=100, h_max=130)  # blue only, as a user would tune it
    wait_until(app, lambda: gui.last_shown_generation >= gui.worker.generation)
    gui.set_view_mode("tabs")
    gui.stage_views.tabs.setCurrentIndex(1)
    hover(gui, "colour", "blue")
    save(app, gui, out / "define_hsv_blue_tabs.png")
    close(gui)


def feature(app: QApplication, settings: QSettings, out: Path) -> None:
    from objrec2d import DemoScene

    system = starting_system("feature")
    detector = system.module("poster")
    detector.clear_target()  # the shipped file holds one: select it as a user would
    gui = window(system, settings, "grid")
    step_to(app, gui, 0)
    gui.hand_selection(Rect(*DemoScene().target.reference_rect), gui.last_results)  # what a mouse drag does
    wait_until(app, lambda: detector.target is not None)
    step_to(app, gui, 75)
    save(app, gui, out / "define_feature.png")
    close(gui)


def shape(app: QApplication, settings: QSettings, out: Path) -> None:
    source = open_source("demo", "3d")
    gui = window(starting_system("shape"), settings, "grid", source=source)
    step_to(app, gui, 0)
    view = gui.view3d.cloud_view
    view.camera.rotate(0.45, -0.25)  # turned a little, so depth shows
    view.camera.zoom(0.75)
    gui.view3d.point_size.setValue(2)  # through its spin box, as a user would
    save(app, gui, out / "define_shape.png")
    close(gui)


def drag(view: object, start: QPointF, end: QPointF, modifiers: object = Qt.KeyboardModifier.NoModifier) -> None:
    """A mouse drag on a stage view, in widget coordinates, as a user's hand would make it."""
    left, none = Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton
    steps = [(QEvent.Type.MouseButtonPress, start, left, left)]
    steps += [(QEvent.Type.MouseMove, start + (end - start) * (i / 4), left, none) for i in range(1, 5)]
    steps.append((QEvent.Type.MouseButtonRelease, end, none, left))
    for kind, pos, buttons, button in steps:
        event = QMouseEvent(kind, pos, QPointF(view.mapToGlobal(pos.toPoint())), button, buttons, modifiers)
        QApplication.sendEvent(view, event)


def eyedropper(app: QApplication, settings: QSettings, out: Path) -> None:
    """The HSV filter opened wide, then set by one Shift+drag inside the red disk."""
    system = starting_system("hsv")
    system.module("colour").reset_parameters()  # pass-everything: the eyedropper sets the ranges
    gui = window(system, settings, "grid")
    step_to(app, gui, 0)
    x, y = next(o["centroid"] for o in gui.last_results.frame.truth["objects"] if o["name"] == "red")
    view = gui.stage_views.view("input")
    generation = gui.worker.generation
    drag(view, view.to_widget(QPointF(x - 20, y - 20)), view.to_widget(QPointF(x + 20, y + 20)),
         Qt.KeyboardModifier.ShiftModifier)
    wait_until(app, lambda: gui.last_shown_generation > generation)
    save(app, gui, out / "define_eyedropper.png")
    close(gui)


def messages(app: QApplication, settings: QSettings, out: Path) -> None:
    """A refused file and a detector moved above its filter, both kept whole in the message area."""
    gui = window(starting_system("hsv"), settings, "grid")
    step_to(app, gui, 0)
    with tempfile.TemporaryDirectory() as folder:
        broken = Path(folder) / "tuned.yaml"
        broken.write_text("format_version: 1\nkind: 2d\npipeline:\n- type: HSVFilter\n  id: colour\n"
                          "  parameters: {h_min: 300}\n")
        gui.files.load(broken)
    settle(app)
    if gui.message_area.dialog is not None:
        gui.message_area.dialog.close()  # the dialog said it too; the picture shows the kept message
    gui.system.move_module("blobs", 0)
    wait_until(app, lambda: gui.last_shown_generation >= gui.worker.generation)
    gui.resizeDocks([gui.message_area], [200], Qt.Orientation.Vertical)
    save(app, gui, out / "define_messages.png")
    close(gui)


def seek_folder(app: QApplication, settings: QSettings, out: Path) -> None:
    """A folder of pictures: the seek bar's counter and the name of the file on screen."""
    import cv2

    from objrec2d import DemoScene

    with tempfile.TemporaryDirectory() as folder:
        scene = DemoScene()
        for index in range(0, 60, 3):
            cv2.imwrite(str(Path(folder) / f"shelf_{index:03d}.png"), scene.render(index)[0])
        gui = window(starting_system("hsv"), settings, "tabs", source=folder)
        wait_until(app, lambda: gui.seek_bar.slider.isEnabled())
        gui.seek_bar.slider.setValue(12)  # as a click on the bar does: frame 13 of 20
        wait_until(app, lambda: gui.last_results is not None and gui.last_results.frame.index == 12)
        save(app, gui, out / "define_seek_folder.png")
        close(gui)


def mug(app: QApplication, settings: QSettings, out: Path) -> None:
    """The real mug scan (PCL's cylinder tutorial), the view fitted to the cylinder the pipeline finds."""
    scan = MUG
    if not scan.is_file():
        print(f"skipped define_mug.png: {scan} is absent", file=sys.stderr)
        return
    from objrec3d import DistanceFilter, PlaneRemovalFilter, ShapeDetector

    system = RecognitionSystem([DistanceFilter(max_distance=1.5), PlaneRemovalFilter(), ShapeDetector()],
                               object_name="mug")
    gui = window(system, settings, "grid", source=str(scan))
    step_to(app, gui, 0)
    wait_until(app, lambda: not gui.view3d.is_busy)
    assert len(gui.last_results.objects.objects) == 1, "the mug was not found"
    view = gui.view3d.cloud_view
    view.camera.rotate(0.3, -0.2)
    gui.view3d.fit_detections.click()
    view.camera.zoom(2.5)  # the table around the mug too
    gui.view3d.point_size.setValue(2)
    save(app, gui, out / "define_mug.png")
    close(gui)


def mug_preview(app: QApplication, settings: QSettings, out: Path) -> None:
    """The shipped shape system tuned on the mug scan: the coarse preview of a change on screen, before the full
    result replaces it."""
    if not MUG.is_file():
        print(f"skipped define_mug_preview.png: {MUG} is absent", file=sys.stderr)
        return
    gui = window(starting_system("shape"), settings, "grid", source=str(MUG))
    step_to(app, gui, 0)
    wait_until(app, lambda: gui.view3d.full_results_shown >= 1, timeout=120)
    view = gui.view3d.cloud_view
    view.camera.rotate(0.3, -0.2)
    gui.view3d.fit_detections.click()
    view.camera.zoom(2.5)
    gui.view3d.point_size.setValue(2)
    settle(app)
    previews = gui.view3d.previews_shown
    gui.system.module("cylinder").set_parameters(min_radius=0.03)
    wait_until(app, lambda: gui.view3d.previews_shown > previews or gui.view3d.full_results_shown > 1, timeout=120)
    if gui.view3d.preview_step:
        QApplication.sendPostedEvents(None, QEvent.Type.LayoutRequest)  # the new summary laid out, nothing else
        save(app, gui, out / "define_mug_preview.png", wait=False)  # now, before the full result replaces it
    else:
        print("skipped define_mug_preview.png: the full result came first (the pipeline is fast here)",
              file=sys.stderr)
    close(gui)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "images")
    parser.add_argument("--only", action="append",
                        choices=("empty", "hsv", "feature", "shape", "mug", "mug_preview", "eyedropper", "messages",
                                 "seek"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    with tempfile.TemporaryDirectory() as folder:
        settings = QSettings(str(Path(folder) / "settings.ini"), QSettings.Format.IniFormat)
        makers = {"empty": empty_window, "hsv": hsv, "feature": feature, "shape": shape, "mug": mug,
                  "mug_preview": mug_preview, "eyedropper": eyedropper, "messages": messages, "seek": seek_folder}
        for name in args.only or list(makers):
            makers[name](app, settings, args.out)
            settings.clear()
    return 0


if __name__ == "__main__":
    sys.exit(main())
