"""A source opened while paused shows its first frame; a click on the seek bar goes
where it points; after a failed seek the thumb and the counter agree; a truncated video offers only its
decodable frames and Loop starts it again."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QStyle, QStyleOptionSlider

from objrec_apps.define import starting_system
from objrec_apps.gui.stage_views import NO_FRAME
from objrec_core import SourceError, open_source
from strictio.errors import InputError
from tests.gui.test_gui_seek import open_paused, write_folder
from tests.qt_waits import HANG_GUARD_MS

SIZE = (64, 48)


def truncated_video(path: Path, frames: int = 40, keep: float = 0.6) -> tuple[Path, int]:
    """An MJPG video of ``frames`` frames cut to ``keep`` of its bytes, and how many frames of it decode."""
    whole = path.with_name("whole.avi")
    writer = cv2.VideoWriter(str(whole), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, SIZE)
    assert writer.isOpened()
    for index in range(frames):
        writer.write(np.full((SIZE[1], SIZE[0], 3), (20 + 6 * index) % 250, np.uint8))
    writer.release()
    data = whole.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])
    decodable = 0
    with open_source(str(path), "2d") as source:
        assert source.length == frames  # the file still states the whole length
        try:
            for _ in source:
                decodable += 1
        except (SourceError, InputError):
            pass
    if not 2 <= decodable < frames - 1:
        pytest.skip(f"this OpenCV decodes {decodable} of the {frames} frames of the cut video")
    return path, decodable


# -- opened while paused ----------------------------------------------------------------------------------------
@pytest.mark.timeout(120)
def test_starting_paused_shows_the_first_frame(make_gui, qtbot):
    """objrec-define --paused: paused on the first frame, not on "No frame yet"."""
    gui = make_gui(starting_system("hsv"), paused=True, first_frame=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as shown:
        pass
    assert shown.args[0].results.frame.index == 0 and gui.worker.paused
    qtbot.wait(100)
    assert gui.worker.processed == 1  # one frame, then it stays paused


@pytest.mark.timeout(120)
def test_a_source_opened_while_paused_shows_its_first_frame(make_gui, qtbot, tmp_path):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    qtbot.waitUntil(lambda: "paused before its first frame" in gui.stage_views.placeholder.text(),
                    timeout=HANG_GUARD_MS)
    assert gui.stage_views.placeholder.text() != NO_FRAME  # a source is open: the page says so
    folder = write_folder(tmp_path / "shots", 3)
    shown = []
    gui.frameShown.connect(shown.append)
    gui.open_source(str(folder))
    qtbot.waitUntil(lambda: bool(shown), timeout=HANG_GUARD_MS)
    frame = shown[0].results.frame
    assert frame.index == 0 and frame.source.startswith(str(folder)) and gui.worker.paused
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as stepped:
        gui.worker.step()
    assert stepped.args[0].results.frame.index == 1  # Step goes on from the frame on screen


# -- the seek bar -----------------------------------------------------------------------------------------------
def groove_point(slider, value: int) -> QPoint:
    """Where on ``slider`` the thumb's centre is for ``value`` (a click there goes to ``value``)."""
    option = QStyleOptionSlider()
    slider.initStyleOption(option)
    groove = slider.style().subControlRect(QStyle.ComplexControl.CC_Slider, option,
                                           QStyle.SubControl.SC_SliderGroove, slider)
    handle = slider.style().subControlRect(QStyle.ComplexControl.CC_Slider, option,
                                           QStyle.SubControl.SC_SliderHandle, slider)
    span = groove.width() - handle.width()
    x = groove.x() + handle.width() // 2 + QStyle.sliderPositionFromValue(slider.minimum(), slider.maximum(),
                                                                          value, span)
    return QPoint(x, slider.height() // 2)


@pytest.mark.timeout(120)
def test_a_click_on_the_seek_bar_goes_to_the_frame_clicked(make_gui, qtbot, tmp_path):
    folder = tmp_path / "shots"
    folder.mkdir()
    for index in range(40):
        cv2.imwrite(str(folder / f"frame{index:02d}.png"), np.full((SIZE[1], SIZE[0], 3), 5 * index, np.uint8))
    gui = open_paused(make_gui, str(folder))
    slider = gui.seek_bar.slider
    qtbot.waitUntil(lambda: slider.maximum() == 39, timeout=HANG_GUARD_MS)
    requested: list[int] = []
    gui.seek_bar.seekRequested.connect(requested.append)
    QTest.mouseClick(slider, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, groove_point(slider, 30))
    assert len(requested) == 1 and abs(requested[0] - 30) <= 1, requested  # not 10 frames on from the thumb
    qtbot.waitUntil(lambda: gui.seek_bar.counter_text == f"frame {requested[0] + 1} / 40", timeout=HANG_GUARD_MS)
    assert slider.value() == requested[0]


@pytest.mark.timeout(120)
def test_a_truncated_video_offers_only_its_decodable_frames_and_loops(make_gui, qtbot, tmp_path):
    video, decodable = truncated_video(tmp_path / "cut.avi")
    gui = make_gui(starting_system("hsv"), source=str(video))
    qtbot.waitUntil(lambda: gui.worker.ended, timeout=HANG_GUARD_MS)
    bar = gui.seek_bar
    qtbot.waitUntil(lambda: bar.slider.maximum() == decodable - 1, timeout=HANG_GUARD_MS)
    assert bar.counter_text == f"frame {decodable} / {decodable}" and bar.slider.value() == decodable - 1
    indices: list[int] = []
    gui.frameShown.connect(lambda shown: indices.append(shown.results.frame.index))
    bar.loop_box.setChecked(True)
    gui.set_paused(False)
    gui.worker.seek(decodable - 2)  # near the end again: the broken frame comes next, then Loop starts over
    qtbot.waitUntil(lambda: decodable - 1 in indices and 0 in indices[indices.index(decodable - 1):],
                    timeout=HANG_GUARD_MS)
    bar.loop_box.setChecked(False)
    gui.set_paused(True)


@pytest.mark.timeout(120)
def test_after_a_failed_seek_the_thumb_and_the_counter_agree(make_gui, qtbot, tmp_path):
    video, decodable = truncated_video(tmp_path / "cut.avi")
    gui = make_gui(starting_system("hsv"), source=str(video), paused=True, first_frame=True, wait=False)
    bar = gui.seek_bar
    qtbot.waitUntil(lambda: bar.counter_text == "frame 1 / 40", timeout=HANG_GUARD_MS)
    bar.slider.setValue(35)  # past what decodes: the seek fails
    qtbot.waitUntil(lambda: "cannot be decoded" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: bar.slider.value() == 0, timeout=HANG_GUARD_MS)
    assert bar.slider.maximum() < 35 and bar.counter_text.startswith("frame 1 / ")
    assert bar.slider.maximum() >= decodable - 1
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as stepped:  # the source still plays
        gui.worker.step()
    assert stepped.args[0].results.frame.index in (0, 1)
