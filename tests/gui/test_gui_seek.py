"""Moving through recordings: the seek bar jumps to frame N of a video, a folder and a bag; the counter and a
folder's file name follow; loop; videos play at their own rate and folders at the set one; the sources'
``frames_from`` gives the same frames a full iteration gives from N on."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec_apps.define import starting_system
from objrec_core import SourceError, open_source
from tests.qt_waits import HANG_GUARD_MS

SIZE = (64, 48)  # width, height


def shade(index: int) -> int:
    """The grey level frame ``index`` is filled with: far enough apart to survive JPEG compression."""
    return 20 + 25 * index


def write_video(path: Path, frames: int, fps: float) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, SIZE)
    assert writer.isOpened()
    for index in range(frames):
        writer.write(np.full((SIZE[1], SIZE[0], 3), shade(index), np.uint8))
    writer.release()
    return path


def write_folder(path: Path, frames: int) -> Path:
    path.mkdir()
    for index in range(frames):
        cv2.imwrite(str(path / f"frame{index}.png"), np.full((SIZE[1], SIZE[0], 3), shade(index), np.uint8))
    return path


def level(frame_data: np.ndarray) -> int:
    return round(float(frame_data.mean()))


@pytest.mark.parametrize("what", ["video", "folder"])
def test_frames_from_n_are_the_frames_a_full_run_gives_from_n(tmp_path, what):
    path = write_video(tmp_path / "clip.avi", 8, 15.0) if what == "video" else write_folder(tmp_path / "shots", 8)
    with open_source(str(path), "2d") as source:
        assert source.seekable and source.length == 8
        full = [(f.index, level(f.data)) for f in source]
    with open_source(str(path), "2d") as source:
        assert [(f.index, level(f.data)) for f in source.frames_from(5)] == full[5:]
        assert [(f.index, level(f.data)) for f in source.frames_from(2)][:2] == full[2:4]
        assert list(source.frames_from(8)) == []
    assert [abs(lv - shade(i)) <= 3 for i, lv in full] == [True] * 8


def test_cameras_and_the_endless_demo_cannot_seek():
    source = open_source("demo", "2d")
    assert not source.seekable
    with pytest.raises(SourceError, match="not seekable"):
        source.frames_from(3)


def test_a_cloud_folder_seeks(tmp_path):
    from objrec3d.cloud import PointCloud
    from objrec3d.pcd import write_pcd

    folder = tmp_path / "clouds"
    folder.mkdir()
    for index in range(4):
        write_pcd(folder / f"c{index}.pcd", PointCloud(np.full((index + 1, 3), float(index), np.float32)))
    source = open_source(str(folder), "3d")
    frames = list(source.frames_from(2))
    assert [f.index for f in frames] == [2, 3]
    assert [len(f.data.points) for f in frames] == [3, 4]
    assert frames[0].source == str(folder / "c2.pcd")


def open_paused(make_gui, source):
    """A window on ``source`` that has shown its first frame, then paused (seeking must work paused)."""
    gui = make_gui(starting_system("hsv"), source=source)
    gui.set_paused(True)
    return gui


def wait_for_index(qtbot, shown, index):
    qtbot.waitUntil(lambda: any(s.results.frame.index == index for s in shown), timeout=HANG_GUARD_MS)
    return next(s.results.frame for s in shown if s.results.frame.index == index)


def test_the_seek_bar_jumps_to_frame_n_of_a_video(make_gui, qtbot, tmp_path):
    video = write_video(tmp_path / "clip.avi", 10, 15.0)
    gui = open_paused(make_gui, str(video))
    assert gui.seek_bar.slider.isEnabled() and gui.seek_bar.slider.maximum() == 9
    assert gui.worker.frame_period() == pytest.approx(1 / 15)  # its own rate, not 30
    shown = []
    gui.frameShown.connect(shown.append)
    gui.seek_bar.slider.setValue(7)  # what a click or a released drag does
    frame = wait_for_index(qtbot, shown, 7)
    assert abs(level(frame.data) - shade(7)) <= 3
    qtbot.waitUntil(lambda: gui.seek_bar.counter_text == "frame 8 / 10", timeout=HANG_GUARD_MS)
    assert gui.worker.paused  # seeking while paused shows the frame and stays paused
    assert gui.seek_bar.file_label.text() == ""  # a video's frames are the video itself
    assert gui.source_bar.kind.currentText() == "file"  # the bar shows the real source, not "demo"
    assert gui.source_bar.name_label.text().strip() == str(video)


def test_the_seek_bar_jumps_to_frame_n_of_a_folder_and_names_the_file(make_gui, qtbot, tmp_path):
    folder = write_folder(tmp_path / "shots", 6)
    gui = open_paused(make_gui, str(folder))
    assert gui.worker.frame_period() == pytest.approx(1 / 5.0)  # the set rate, not flat out
    gui.seek_bar.rate_box.setValue(12.0)
    assert gui.worker.frame_period() == pytest.approx(1 / 12.0)
    shown = []
    gui.frameShown.connect(shown.append)
    gui.seek_bar.slider.setValue(4)
    frame = wait_for_index(qtbot, shown, 4)
    assert level(frame.data) == shade(4)
    qtbot.waitUntil(lambda: gui.seek_bar.counter_text == "frame 5 / 6", timeout=HANG_GUARD_MS)
    assert gui.seek_bar.file_label.text().strip() == "frame4.png"
    assert gui.source_bar.kind.currentText() == "folder"


def test_loop_starts_a_folder_again(make_gui, qtbot, tmp_path):
    folder = write_folder(tmp_path / "shots", 3)
    gui = open_paused(make_gui, str(folder))
    gui.seek_bar.rate_box.setValue(60.0)
    gui.seek_bar.loop_box.setChecked(True)
    indices = []
    gui.frameShown.connect(lambda s: indices.append(s.results.frame.index))
    gui.set_paused(False)
    qtbot.waitUntil(lambda: len(indices) >= 6, timeout=HANG_GUARD_MS)
    assert not gui.worker.ended
    assert 2 in indices and 0 in indices[indices.index(2):]  # after the last frame, the first again
    gui.seek_bar.loop_box.setChecked(False)
    qtbot.waitUntil(lambda: gui.worker.ended, timeout=HANG_GUARD_MS)


def test_the_endless_demo_has_no_seek_bar(make_gui):
    gui = make_gui(starting_system("hsv"), source="demo")
    assert not gui.seek_bar.slider.isEnabled()
    assert not gui.seek_bar.loop_box.isEnabled()
    counter = gui.seek_bar.counter_text
    assert counter.startswith("frame ") and "/" not in counter  # a frame number, of no known total


def record_demo(project_root, path, frames):
    spec = importlib.util.spec_from_file_location("record_demo_bag", project_root / "scripts" / "record_demo_bag.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.record(path, frames, ["2d"], 0)


def test_the_seek_bar_jumps_to_frame_n_of_a_bag(make_gui, qtbot, project_root, tmp_path):
    pytest.importorskip("rosbags")
    bag = tmp_path / "demo.bag"
    record_demo(project_root, bag, 6)
    expected = [f.data for f in open_source("demo:frames=6", "2d")]
    with open_source(str(bag), "2d") as source:
        assert source.seekable and source.length == 6
        frames = list(source.frames_from(4))
        assert [f.index for f in frames] == [4, 5]
        assert all(np.array_equal(f.data, expected[f.index]) for f in frames)
    gui = open_paused(make_gui, str(bag))
    assert gui.seek_bar.slider.maximum() == 5
    assert gui.worker.frame_period() == pytest.approx(1 / open_source(str(bag), "2d").rate)
    shown = []
    gui.frameShown.connect(shown.append)
    gui.seek_bar.slider.setValue(3)
    frame = wait_for_index(qtbot, shown, 3)
    assert np.array_equal(frame.data, expected[3])
    qtbot.waitUntil(lambda: gui.seek_bar.counter_text == "frame 4 / 6", timeout=HANG_GUARD_MS)
