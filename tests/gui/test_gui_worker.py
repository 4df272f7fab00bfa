"""Processing off the GUI thread: only the newest result is shown and nothing queues up behind a busy
GUI; parameter changes are shown at once, also while paused; stepping, ended sources, failing modules,
bad sources; tabs or grid for the stage views."""

from __future__ import annotations

import time

import cv2
import numpy as np
from PySide6.QtWidgets import QApplication

from objrec2d import ImageFilter
from objrec_apps.define import starting_system
from objrec_core import Bool, RecognitionSystem
from tests.qt_waits import HANG_GUARD_MS


def test_a_busy_gui_skips_frames_instead_of_queueing_them(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), fps_limit=None)
    shown = []
    gui.frameShown.connect(shown.append)
    processed = gui.worker.processed
    time.sleep(1.0)  # the GUI thread is busy: no events are handled, the worker keeps going
    assert gui.worker.processed - processed >= 3
    QApplication.processEvents()
    assert len(shown) == 1, "one frame shown for the whole backlog"
    assert shown[0].results.frame.index >= gui.worker.processed - 2  # and it is the newest
    assert gui.worker.dropped >= 2


def test_a_parameter_change_while_paused_reprocesses_the_frame_on_screen(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as first:
        gui.worker.step()
    assert first.args[0].results.frame.index == 0 and len(first.args[0].results.objects) == 4
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as again:
        gui.panels.panel("colour").editors["s_min"].spin.setValue(255)  # nothing is that saturated
    shown = again.args[0]
    assert shown.results.frame.index == 0 and len(shown.results.objects) == 0
    assert shown.generation > first.args[0].generation
    assert gui.worker.paused
    generation = gui.worker.generation
    gui.system.description = "a new description"  # changes nothing the pipeline finds: no reprocessing
    assert gui.worker.generation == generation
    gui.system.object_name = "thing"  # the objects' name: reprocessed
    assert gui.worker.generation == generation + 1


def test_single_steps_take_one_frame_each(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    indexes = []
    for _ in range(3):
        with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as signal:
            gui.source_bar.step_action.trigger()
        indexes.append(signal.args[0].results.frame.index)
    assert indexes == [0, 1, 2]
    qtbot.wait(150)
    assert gui.worker.processed == 3


def test_a_change_while_running_shows_within_a_frame_or_two(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    module = gui.system.module("colour")
    frames = []  # counted, not timed: how many frames the worker processed until the change was shown
    for value in (130, 140, 150, 160, 170):
        before = gui.worker.processed
        module.set_parameters(s_min=value)
        generation = gui.worker.generation
        qtbot.waitUntil(lambda g=generation: gui.last_shown_generation >= g, timeout=120_000)  # a hang guard
        frames.append(gui.worker.processed - before)
    assert 1 <= sorted(frames)[2] <= 2, f"frames processed until a change showed: {frames}"


def test_an_image_file_ends_and_still_answers_parameter_changes(make_gui, qtbot, tmp_path):
    from objrec2d import DemoScene

    image, _ = DemoScene().render(0)
    path = tmp_path / "frame.png"
    cv2.imwrite(str(path), image)
    gui = make_gui(starting_system("hsv"), source=str(path))
    qtbot.waitUntil(lambda: "(ended)" in gui.source_bar.name_label.text(), timeout=HANG_GUARD_MS)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as signal:
        gui.system.module("blobs").set_parameters(min_contour_length=1000.0)
    assert len(signal.args[0].results.objects) == 0 and signal.args[0].results.frame.index == 0


class Fragile(ImageFilter):
    """Fails on every frame while ``broken`` is set."""

    broken = Bool(False, "raise on every frame")

    def filter(self, frame):
        if self.params.broken:
            raise RuntimeError("the filter broke")
        return frame


def test_a_failing_module_is_reported_and_the_window_keeps_running(make_gui, qtbot):
    system = starting_system("hsv")
    system.add_module(Fragile("fragile"), 0)
    gui = make_gui(system)
    system.module("fragile").set_parameters(broken=True)
    qtbot.waitUntil(lambda: "the filter broke" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    assert "RuntimeError" in gui.statusBar().currentMessage()
    system.module("fragile").set_parameters(broken=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        pass


def test_a_source_that_cannot_be_opened_is_reported(make_gui, qtbot, tmp_path):
    gui = make_gui(starting_system("hsv"))
    gui.open_source(str(tmp_path / "missing.png"))
    qtbot.waitUntil(lambda: "no such file or folder" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):  # the old source goes on
        pass


def test_stages_as_tabs_or_as_a_grid(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), view_mode="tabs")
    views = gui.stage_views
    assert list(views.views) == ["input", "colour", "open", "blobs"]
    assert views.tabs.count() == 4 and [views.tabs.tabText(i) for i in range(4)][:2] == [
        "original + detections", "colour (HSVFilter)"]
    assert sum(v.isVisible() for v in views.views.values()) == 1
    gui.set_view_mode("grid")
    qtbot.waitUntil(lambda: all(v.isVisible() for v in views.views.values()))
    painted = {key: view.paint_count for key, view in views.views.items()}
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        pass
    qtbot.waitUntil(lambda: all(v.paint_count > painted[k] for k, v in views.views.items()), timeout=HANG_GUARD_MS)
    mask = views.view("colour").image()  # the kind's preview of the mask: grey BGR
    assert mask.shape == (480, 640, 3) and set(np.unique(mask)) == {0, 255}
    assert (mask == mask[..., :1]).all()


def test_closing_the_window_stops_processing(make_gui):
    gui = make_gui(RecognitionSystem(starting_system("hsv").modules))
    thread = gui.worker._thread
    gui.close()
    assert thread is not None and not thread.is_alive()
    assert gui.system.module("colour").observers == ()


def test_the_source_bar_opens_files_folders_cameras_and_the_demo(make_gui, qtbot, monkeypatch, tmp_path):
    from PySide6.QtWidgets import QFileDialog

    from objrec2d import DemoScene

    for index in range(3):
        cv2.imwrite(str(tmp_path / f"frame{index}.png"), DemoScene().render(index)[0])
    gui = make_gui(starting_system("hsv"))
    bar = gui.source_bar
    filters: list[str] = []

    def get_open(parent, caption, folder, file_filter):
        filters.append(file_filter)
        return str(tmp_path / "frame1.png"), ""

    monkeypatch.setattr(QFileDialog, "getOpenFileName", staticmethod(get_open))
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", staticmethod(lambda *a: str(tmp_path)))
    bar.kind.setCurrentText("file")
    bar.open_button.click()
    qtbot.waitUntil(lambda: bar.name_label.text().strip() == f"{tmp_path / 'frame1.png'} (ended)",
                    timeout=HANG_GUARD_MS)
    (offered,) = filters  # what the pipeline's kind (2d) reads: images and videos, no clouds
    assert offered.startswith("Files 2d sources read (") and "*.png" in offered and "*.mp4" in offered
    assert "*.pcd" not in offered
    assert gui.last_results.frame.source == str(tmp_path / "frame1.png")
    assert gui.files.last_folder() == str(tmp_path)
    bar.kind.setCurrentText("folder")
    bar.open_button.click()
    qtbot.waitUntil(lambda: "(ended)" in bar.name_label.text() and gui.last_results.frame.index == 2,
                    timeout=HANG_GUARD_MS)
    bar.kind.setCurrentText("camera")
    bar.camera_number.setValue(63)
    bar.open_button.click()  # no such camera here: reported, and the folder's last frame stays
    qtbot.waitUntil(lambda: "camera:63" in gui.statusBar().currentMessage()
                    and "cannot open" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    bar.kind.setCurrentText("spec")
    assert bar.spec_action.isVisible() and not bar.camera_action.isVisible()
    bar.spec_edit.setText("demo:seed=3")
    bar.open_button.click()  # any spec a source of the pipeline's kind reads
    qtbot.waitUntil(lambda: bar.name_label.text().strip() == "demo:seed=3", timeout=HANG_GUARD_MS)
    assert gui.worker.source.length is None  # the demo is endless unless frames= says otherwise
    bar.kind.setCurrentText("demo")
    bar.open_button.click()
    qtbot.waitUntil(lambda: bar.name_label.text().strip() == "demo", timeout=HANG_GUARD_MS)
    bar.pause_action.trigger()
    assert gui.worker.paused and bar.pause_action.text() == "Resume"


def test_help_about_explains_the_window(make_gui, monkeypatch):
    from PySide6.QtWidgets import QMessageBox

    shown = []
    monkeypatch.setattr(QMessageBox, "about", staticmethod(lambda parent, title, text: shown.append((title, text))))
    gui = make_gui(starting_system("hsv"), wait=False)
    gui.about_action.trigger()
    (title, text), = shown
    assert title == "About objrec-define" and "objrec-detect" in text and "Pipeline" in text


def test_a_source_that_breaks_mid_stream_is_reported_and_its_last_frame_stays(make_gui, qtbot):
    from objrec2d import DemoSource
    from objrec_core import FrameSource, SourceError

    class Breaking(FrameSource):
        name = "flaky"

        def __iter__(self):
            yield from (frame for _, frame in zip(range(2), DemoSource(), strict=False))
            raise SourceError("flaky: the cable came loose")

    gui = make_gui(starting_system("hsv"), source=Breaking())
    qtbot.waitUntil(lambda: "the cable came loose" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    assert gui.worker.ended and gui.last_results.frame.index == 1
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as signal:
        gui.system.module("colour").set_parameters(h_min=1)
    assert signal.args[0].results.frame.index == 1
