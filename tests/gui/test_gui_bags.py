"""The definition GUI opens a recording as a source: it asks which topic when there are several, then plays it."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from objrec_apps.gui.topic_chooser import with_topic
from objrec_core import build_system, open_source
from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("rosbags")


def record_demo(project_root, path, frames):
    spec = importlib.util.spec_from_file_location("record_demo_bag", project_root / "scripts" / "record_demo_bag.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.record(path, frames, ["2d", "3d"], 0)


def test_a_bag_of_two_topics_plays_the_one_of_the_pipelines_kind_without_asking(make_gui, qtbot, project_root,
                                                                                 tmp_path):
    """An image pipeline is not offered the PointCloud2 topic; its only image topic plays."""
    bag = tmp_path / "demo.bag"
    assert record_demo(project_root, bag, 4) == {"/camera/color/image_raw": 4, "/camera/depth/points": 4}
    gui = make_gui(build_system(project_root / "params" / "hsv_demo.yaml"), source="demo:frames=1")
    asked = []

    def choose(title, labels):
        asked.append((title, labels))
        return next(label for label in labels if label.startswith("/camera/color/image_raw"))

    gui.ask_choice = choose
    expected = [f.data for f in open_source("demo:frames=4", "2d")]
    shown = []
    gui.frameShown.connect(lambda item: shown.append(item.results.frame))
    gui.open_source(str(bag))
    qtbot.waitUntil(lambda: len(shown) >= 2, timeout=HANG_GUARD_MS)
    assert asked == []  # one topic of its kind: nothing to choose
    frame = shown[-1]
    assert frame.source.startswith(f"bag:{bag},topic=/camera/color/image_raw")
    assert frame.frame_id == "camera_color_optical_frame"
    assert np.array_equal(frame.data, expected[frame.index])  # the bag's pixels are the demo's
    assert gui.last_results.objects.objects  # and the pipeline finds the coloured objects in them


def test_a_pipeline_of_no_kind_yet_is_asked_which_topic(project_root, tmp_path):
    bag = tmp_path / "demo.bag"
    record_demo(project_root, bag, 4)
    asked = []

    def choose(title, labels):
        asked.append((title, labels))
        return labels[1]

    assert with_topic(str(bag), choose) == f"bag:{bag},topic=/camera/depth/points"
    title, labels = asked[0]
    assert title == f"{bag} holds 2 topics: play which?"
    assert labels == ["/camera/color/image_raw   (sensor_msgs/msg/Image, 4 messages)",
                      "/camera/depth/points   (sensor_msgs/msg/PointCloud2, 4 messages)"]
    assert with_topic(str(bag), choose, "2d") == f"bag:{bag},topic=/camera/color/image_raw"  # its only one
    assert len(asked) == 1


def test_cancelling_the_topic_choice_opens_nothing(make_gui, project_root, tmp_path):
    bag = tmp_path / "demo.bag"
    record_demo(project_root, bag, 1)
    gui = make_gui(None, source=None, wait=False)  # no kind yet: both topics are offered
    gui.ask_choice = lambda title, labels: None
    gui.open_source(str(bag))
    assert gui.statusBar().currentMessage() == f"{bag} not opened: no topic chosen"
