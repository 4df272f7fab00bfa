"""A folder's unreadable files are reported in the message area; status bar
messages are cut at a word, never under the pixel read-out; the frames-shown rate says when frames stopped."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from PySide6.QtGui import QFont, QFontMetrics

from objrec_apps.define import starting_system
from objrec_apps.gui.status_line import ELLIPSIS, fit_at_word
from tests.qt_waits import HANG_GUARD_MS


@pytest.mark.timeout(120)
def test_a_folders_unreadable_file_is_reported_in_the_message_area(make_gui, qtbot, tmp_path):
    folder = tmp_path / "shots"
    folder.mkdir()
    for index in (0, 2):
        cv2.imwrite(str(folder / f"frame{index}.png"), np.full((48, 64, 3), 60 * (index + 1), np.uint8))
    (folder / "frame1.png").write_bytes(b"not a picture at all")
    gui = make_gui(starting_system("hsv"), source=str(folder))
    qtbot.waitUntil(lambda: any("frame1.png" in text for text in gui.message_area.messages()),
                    timeout=HANG_GUARD_MS)
    report = next(text for text in gui.message_area.messages() if "frame1.png" in text)
    assert "skipped" in report and str(folder) in report
    qtbot.waitUntil(lambda: gui.worker.ended, timeout=HANG_GUARD_MS)
    assert gui.last_results.frame.source.endswith("frame2.png")  # the good files were played


def test_a_message_too_long_is_cut_at_a_word():
    metrics = QFontMetrics(QFont())
    text = "selection 40×30 at (10, 10) did nothing: no detector in the pipeline takes selections"
    width = metrics.horizontalAdvance(text) // 2
    shown = fit_at_word(text, metrics, width)
    assert shown.endswith(ELLIPSIS) and metrics.horizontalAdvance(shown) <= width
    start = shown[: -len(ELLIPSIS)]
    assert text.startswith(start) and text[len(start)] in " ,;:"  # it ends where a word ends
    assert fit_at_word(text, metrics, metrics.horizontalAdvance(text)) == text
    assert metrics.horizontalAdvance(fit_at_word("Supercalifragilistic", metrics, 30)) <= 30


@pytest.mark.timeout(120)
def test_the_status_message_stays_left_of_the_pixel_readout(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), size=(1280, 800))
    bar = gui.statusBar()
    text = ("eyedropper: the pipeline has no HSV filter (add one from the Pipeline menu), so the rectangle "
            "you drew set nothing at all; draw it again once the pipeline has one")
    gui.show_message(text, error=True)
    assert bar.currentMessage() == text and bar.toolTip() == text  # the whole text stays available
    for hovering in (False, True):
        gui.stage_views.hovered.emit("x 412, y 355 · BGR (255, 255, 255) · HSV (179, 255, 255)" if hovering else "")
        qtbot.waitUntil(lambda h=hovering: gui.hover_label.isVisible() == h, timeout=HANG_GUARD_MS)
        bar.layout().activate()
        room = bar.message_room()
        for label in (gui.hover_label, gui.path_label):  # the read-out and the path: never under the message
            assert room.right() < label.geometry().left() or not label.isVisible()
        shown = bar.shown_text()
        assert bar.fontMetrics().horizontalAdvance(shown) <= room.width()
        if shown and shown != text:
            assert shown.endswith(ELLIPSIS) and text[len(shown) - len(ELLIPSIS)] in " ,;:"
        if not hovering:
            assert shown  # without the read-out, the message has room
        bar.repaint()  # the bar's own painting runs without error


@pytest.mark.timeout(120)
def test_the_frames_shown_rate_says_paused_and_ended(make_gui, qtbot, tmp_path):
    gui = make_gui(starting_system("hsv"))
    qtbot.waitUntil(lambda: "frames/s shown" in gui.source_bar.fps_label.text(), timeout=HANG_GUARD_MS)
    gui.set_paused(True)
    qtbot.waitUntil(lambda: "paused: 0 frames/s shown" in gui.source_bar.fps_label.text(), timeout=HANG_GUARD_MS)
    path = tmp_path / "one.png"
    cv2.imwrite(str(path), np.full((48, 64, 3), 90, np.uint8))
    gui.set_paused(False)
    gui.open_source(str(path))
    qtbot.waitUntil(lambda: gui.worker.ended, timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: "ended: 0 frames/s shown" in gui.source_bar.fps_label.text(), timeout=HANG_GUARD_MS)
