"""After a source ends (a recording played to its last frame, or stopped at a frame it cannot decode) the source
bar's play/pause button offers Restart instead of a Pause that would pause nothing, and the status bar says the
source ended. Restart plays it again from its first frame: a recording goes back to frame 0, a source that
cannot seek (a demo of set length) is opened again. Seeking after the end makes it play again, and the bar
says so."""

from __future__ import annotations

import pytest

from objrec_apps.define import starting_system
from objrec_apps.gui.source_bar import PAUSE_TIP, RESTART_TIP
from tests.gui.test_gui_items_seek import truncated_video
from tests.gui.test_gui_seek import write_folder, write_video
from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("objrec2d")


def shown_indices(gui) -> list[int]:
    indices: list[int] = []
    gui.frameShown.connect(lambda shown: indices.append(shown.results.frame.index))
    return indices


def assert_ended(gui, name: str) -> None:
    bar = gui.source_bar
    assert bar.ended and bar.pause_action.text() == "Restart" and bar.pause_action.toolTip() == RESTART_TIP
    assert not bar.pause_action.isChecked()
    assert bar.name_label.text().strip() == f"{name} (ended)"
    assert bar.fps_label.text().strip().startswith("ended: 0 frames/s shown")


def assert_playing(gui, name: str) -> None:
    bar = gui.source_bar
    assert not bar.ended and bar.pause_action.text() == "Pause" and bar.pause_action.toolTip() == PAUSE_TIP
    assert bar.name_label.text().strip() == name


@pytest.mark.timeout(120)
def test_a_video_at_its_end_offers_restart_and_plays_again_from_frame_one(make_gui, qtbot, tmp_path):
    video = str(write_video(tmp_path / "clip.avi", 6, 30.0))
    gui = make_gui(starting_system("hsv"), source=video)
    qtbot.waitUntil(lambda: gui.source_bar.ended, timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: "ended" in gui.source_bar.fps_label.text(), timeout=HANG_GUARD_MS)
    assert_ended(gui, video)
    assert gui.statusBar().currentMessage().startswith(f"{video} ended: Restart (Space) plays it again")
    assert gui.seek_bar.counter_text == "frame 6 / 6"
    indices = shown_indices(gui)
    gui.source_bar.pause_action.trigger()  # what Space or a click on the button does
    qtbot.waitUntil(lambda: 5 in indices and gui.source_bar.ended, timeout=HANG_GUARD_MS)
    assert indices[:6] == [0, 1, 2, 3, 4, 5]  # from the first frame, played through, not paused
    assert not gui.worker.paused
    qtbot.waitUntil(lambda: "ended" in gui.source_bar.fps_label.text(), timeout=HANG_GUARD_MS)
    assert_ended(gui, video)  # and at its end again it offers Restart again


@pytest.mark.timeout(120)
def test_while_it_plays_again_the_bar_offers_pause(make_gui, qtbot, tmp_path):
    folder = str(write_folder(tmp_path / "shots", 4))
    gui = make_gui(starting_system("hsv"), source=folder)
    gui.seek_bar.rate_box.setValue(2.0)  # slow enough to look at the bar while it plays
    qtbot.waitUntil(lambda: gui.source_bar.ended, timeout=HANG_GUARD_MS)
    indices = shown_indices(gui)
    gui.source_bar.pause_action.trigger()
    qtbot.waitUntil(lambda: 0 in indices, timeout=HANG_GUARD_MS)
    assert_playing(gui, folder)
    gui.source_bar.pause_action.trigger()  # now a real Pause
    assert gui.worker.paused and gui.source_bar.pause_action.text() == "Resume"
    assert not gui.source_bar.ended


@pytest.mark.timeout(120)
def test_stepping_onto_the_end_offers_restart_which_plays(make_gui, qtbot, tmp_path):
    folder = str(write_folder(tmp_path / "shots", 2))
    gui = make_gui(starting_system("hsv"), source=folder, paused=True, first_frame=True, wait=False)
    bar = gui.source_bar
    qtbot.waitUntil(lambda: gui.last_results is not None, timeout=HANG_GUARD_MS)
    bar.step_action.trigger()  # frame 2
    qtbot.waitUntil(lambda: gui.last_results.frame.index == 1, timeout=HANG_GUARD_MS)
    bar.step_action.trigger()  # past the end
    qtbot.waitUntil(lambda: bar.ended, timeout=HANG_GUARD_MS)
    assert gui.worker.paused and bar.pause_action.text() == "Restart" and not bar.pause_action.isChecked()
    indices = shown_indices(gui)
    bar.pause_action.trigger()
    qtbot.waitUntil(lambda: 1 in indices, timeout=HANG_GUARD_MS)
    assert indices[:2] == [0, 1] and not gui.worker.paused  # Restart plays: it is a Play from the start


@pytest.mark.timeout(120)
def test_a_seek_after_the_end_plays_again_and_the_bar_says_so(make_gui, qtbot, tmp_path):
    video = str(write_video(tmp_path / "clip.avi", 6, 30.0))
    gui = make_gui(starting_system("hsv"), source=video)
    qtbot.waitUntil(lambda: gui.source_bar.ended, timeout=HANG_GUARD_MS)
    gui.set_paused(True)
    assert gui.source_bar.pause_action.text() == "Restart"  # paused at the end: still nothing to resume
    indices = shown_indices(gui)
    gui.seek_bar.slider.setValue(2)  # as a click on the seek bar: frame 3, shown paused
    qtbot.waitUntil(lambda: 2 in indices, timeout=HANG_GUARD_MS)
    bar = gui.source_bar
    assert not bar.ended and bar.pause_action.text() == "Resume" and bar.pause_action.isChecked()
    assert bar.name_label.text().strip() == video


@pytest.mark.timeout(120)
def test_a_source_that_cannot_seek_is_opened_again(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), source="demo:frames=3")
    qtbot.waitUntil(lambda: gui.source_bar.ended, timeout=HANG_GUARD_MS)
    assert not gui.worker.facts.seekable
    indices = shown_indices(gui)
    gui.source_bar.pause_action.trigger()
    qtbot.waitUntil(lambda: 2 in indices and gui.source_bar.ended, timeout=HANG_GUARD_MS)
    assert indices[:3] == [0, 1, 2]
    assert any("Opening demo:frames=3…" in text for text in gui.message_area.messages()[-5:])


@pytest.mark.timeout(120)
def test_a_video_stopped_by_a_broken_frame_says_it_ended_and_offers_restart(make_gui, qtbot, tmp_path):
    video, decodable = truncated_video(tmp_path / "cut.avi")
    gui = make_gui(starting_system("hsv"), source=str(video))
    qtbot.waitUntil(lambda: gui.source_bar.ended and gui.worker.ended, timeout=HANG_GUARD_MS)
    assert_ended(gui, str(video))
    status = gui.statusBar().currentMessage()  # where that leaves the source, then the error itself
    assert status.startswith("Ended (Restart plays it again from the start): the source failed: ")
    assert f"frame {decodable} of 40 cannot be decoded" in status
    assert "cannot be decoded" in gui.message_area.messages()[-1]  # the message area keeps the error alone
    indices = shown_indices(gui)
    gui.source_bar.pause_action.trigger()
    qtbot.waitUntil(lambda: decodable - 1 in indices and gui.source_bar.ended, timeout=HANG_GUARD_MS)
    assert indices[:decodable] == list(range(decodable))
