"""objrec-define on a live topic: File > Open topic lists what a ROS 1 (or ROS 2) system publishes, the chosen
topic opens as the source, and the seek bar is hidden while a stream (a live topic, a camera, the endless demo)
plays and shown again for a recording.

The dialog's own behaviour is tested with a stand-in lister; the end-to-end test runs Debian's ``rosmaster``
and a rospy publisher of sensor_msgs/Image (tests/ros/live/ros1_env.py), and skips where ROS 1 is absent; a
ROS 2 domain is listed over DDS on loopback (tests/ros/live/dds_env.py), skipped without cyclonedds.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from PySide6.QtWidgets import QMainWindow

from objrec_apps.define import starting_system
from objrec_apps.gui import live_topic_dialog
from objrec_apps.gui.live_topic_dialog import LiveTopicDialog, listing_error
from objrec_apps.gui.seek_bar import SeekBar, SourceFacts
from objrec_apps.gui.source_bar import chooser_kind
from objrec_apps.gui.topic_chooser import (
    LiveReading,
    is_live_spec,
    live_defaults,
    live_reading,
    live_spec,
    with_topic,
)
from tests.qt_waits import HANG_GUARD_MS
from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out
from tests.ros.live import ros1_env
from tests.ros.live.ros1_env import STARTUP_DEADLINE, RospyNode

ros1_master = ros1_env.ros1_master  # the fixture, used by name
dds_env = dds.dds_env  # the fixture, used by name

TOPICS = [("/camera/rgb/image_raw", "sensor_msgs/msg/Image"), ("/odom", "nav_msgs/msg/Odometry"),
          ("/camera/rgb/image_raw/compressed", "sensor_msgs/msg/CompressedImage")]
IMAGES = frozenset({"sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage"})


# -- the seek bar follows the source ---------------------------------------------------------------------------
def test_a_source_of_unknown_length_that_cannot_seek_is_a_stream():
    assert SourceFacts("ros1:/camera/rgb/image_raw", None, False, None).is_stream
    assert SourceFacts("camera:0", None, False, None).is_stream
    assert not SourceFacts("clip.avi", 300, True, 30.0).is_stream
    assert not SourceFacts("demo:frames=100", 100, False, 30.0).is_stream  # it ends: not a stream


def test_the_seek_bar_hides_for_a_stream_and_comes_back_for_a_recording(qtbot):
    window = QMainWindow()
    qtbot.addWidget(window)
    bar = SeekBar(window)
    window.addToolBar(bar)
    window.show()
    assert bar.isVisible()
    bar.set_source(SourceFacts("ros1:/camera/rgb/image_raw", None, False, None))
    assert bar.isHidden() and not bar.isVisible()
    bar.set_source(SourceFacts("clip.avi", 300, True, 30.0))
    assert bar.isVisible() and bar.slider.isEnabled() and bar.slider.maximum() == 299
    assert bar.counter_text == "frame - / 300"


def test_a_seek_bar_the_user_closed_stays_closed(qtbot):
    window = QMainWindow()
    qtbot.addWidget(window)
    bar = SeekBar(window)
    window.addToolBar(bar)
    window.show()
    bar.toggleViewAction().trigger()  # View > seek bar: the user closes it
    assert bar.isHidden()
    bar.set_source(SourceFacts("camera:0", None, False, None))
    bar.set_source(SourceFacts("clip.avi", 300, True, 30.0))
    assert bar.isHidden()  # not this code's to show again


def write_folder(path: Path, frames: int) -> Path:
    path.mkdir()
    for index in range(frames):
        cv2.imwrite(str(path / f"frame{index}.png"), np.full((48, 64, 3), 40 * index, np.uint8))
    return path


def test_the_window_hides_the_seek_bar_for_the_endless_demo_and_shows_it_for_a_folder(make_gui, qtbot, tmp_path):
    gui = make_gui(starting_system("hsv"), source="demo")
    assert gui.seek_bar.isHidden() and gui.seek_bar.hidden_for_stream
    folder = write_folder(tmp_path / "shots", 3)
    gui.open_source(str(folder))
    qtbot.waitUntil(lambda: gui.seek_bar.isVisible(), timeout=HANG_GUARD_MS)
    assert gui.seek_bar.slider.isEnabled() and gui.seek_bar.slider.maximum() == 2


def test_a_seek_bar_hidden_for_a_stream_comes_back_in_the_next_run(make_gui, qtbot, tmp_path):
    gui = make_gui(starting_system("hsv"), source="demo")
    assert gui.seek_bar.isHidden()
    gui.close()
    again = make_gui(starting_system("hsv"), source="demo")
    assert again.seek_bar.isHidden() and again.seek_bar.hidden_for_stream  # the layout restored, the demo on
    again.open_source(str(write_folder(tmp_path / "shots", 2)))
    qtbot.waitUntil(again.seek_bar.isVisible, timeout=HANG_GUARD_MS)  # hidden by the stream, not by the user


# -- specs -----------------------------------------------------------------------------------------------------
def test_live_specs_spell_out_their_address():
    assert live_spec("ros1", "/camera/rgb/image_raw", {"master": "http://10.0.0.5:11311"}) == \
        "ros1:/camera/rgb/image_raw,master=http://10.0.0.5:11311"
    assert live_spec("ros2", "/camera/color/image_raw", {"domain": "7"}) == "ros2:/camera/color/image_raw,domain=7"
    assert live_defaults({"ROS_MASTER_URI": "http://robot:11311", "ROS_DOMAIN_ID": "3"}) == \
        {"master": "http://robot:11311", "domain": "3"}
    assert live_defaults({}) == {"master": "http://localhost:11311", "domain": "0"}
    assert live_defaults({"ROS_DOMAIN_ID": "x"})["domain"] == "0"
    assert is_live_spec("ros1:/a") and is_live_spec("ROS2:/a,domain=1")
    assert not is_live_spec("demo:seed=3") and not is_live_spec("ros1.png")
    assert chooser_kind("ros1:/camera/rgb/image_raw,master=http://127.0.0.1:11311") == "topic"
    assert with_topic("ros1:/camera/rgb/image_raw", lambda *_: None) == "ros1:/camera/rgb/image_raw"


def test_a_failed_listing_is_one_line_naming_the_address():
    line = listing_error("ros1", {"master": "http://127.0.0.1:9"}, ConnectionRefusedError(111, "refused"))
    assert line == "ROS 1 topics on http://127.0.0.1:9 cannot be listed: [Errno 111] refused"
    missing = ModuleNotFoundError("No module named 'cyclonedds'", name="cyclonedds")
    assert listing_error("ros2", {"domain": "0"}, missing) == \
        'ROS 2 topics cannot be listed: cyclonedds is not installed (pip install "objrec[ros2]")'


# -- the dialog with a stand-in lister -------------------------------------------------------------------------
def open_dialog(qtbot, kind, lister, **options):
    dialog = LiveTopicDialog(kind, lister=lister, environ={"ROS_MASTER_URI": "http://robot:11311"}, **options)
    qtbot.addWidget(dialog)
    with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
        dialog.show()
    return dialog


def test_the_dialog_lists_topics_and_greys_the_types_the_pipeline_cannot_read(qtbot, monkeypatch):
    monkeypatch.setattr(live_topic_dialog, "live_reading", lambda kind, scheme: LiveReading(IMAGES, "images"))
    asked = []

    def lister(scheme, options, timeout):
        asked.append((scheme, dict(options), threading.current_thread() is threading.main_thread()))
        return list(TOPICS)

    dialog = open_dialog(qtbot, "2d", lister)
    assert asked == [("ros1", {"master": "http://robot:11311"}, False)]  # never in the GUI thread
    assert dialog.topic_names() == [("/camera/rgb/image_raw", "sensor_msgs/msg/Image", True),
                                    ("/camera/rgb/image_raw/compressed", "sensor_msgs/msg/CompressedImage", True),
                                    ("/odom", "nav_msgs/msg/Odometry", False)]
    assert dialog.status.text() == "3 topics on http://robot:11311, 2 readable by this 2d pipeline"
    assert dialog.topics.topLevelItem(2).toolTip(0) == "a 2d pipeline does not read nav_msgs/msg/Odometry"
    assert dialog.note.text() == "Greyed: types a 2d pipeline cannot read; it reads images."
    with pytest.raises(KeyError):
        dialog.choose("/nowhere")
    dialog.choose("/odom")  # greyed: not accepted
    assert dialog.spec == "" and dialog.result() == 0
    dialog.choose("/camera/rgb/image_raw")
    assert dialog.spec == "ros1:/camera/rgb/image_raw,master=http://robot:11311"
    assert dialog.result() == LiveTopicDialog.DialogCode.Accepted


def test_ros2_lists_on_the_domain_and_refresh_lists_again(qtbot):
    calls = []

    def lister(scheme, options, timeout):
        calls.append((scheme, dict(options)))
        return [("/chatter", "std_msgs/msg/String")] * (len(calls) > 2)

    dialog = open_dialog(qtbot, None, lister)
    with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
        dialog.domain.setValue(5)
        dialog.set_transport("ros2")
    assert calls[-1] == ("ros2", {"domain": "5"})
    assert dialog.status.text() == "Nothing is published on domain 5 now: start the robot's camera node, then Refresh"
    with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
        dialog.refresh_button.click()
    assert dialog.topic_names() == [("/chatter", "std_msgs/msg/String", True)]  # no kind yet: everything offered
    dialog.choose("/chatter")
    assert dialog.spec == "ros2:/chatter,domain=5"


def test_a_listing_that_never_answers_gives_up_with_one_line(qtbot, monkeypatch):
    monkeypatch.setattr(live_topic_dialog, "LIST_SLACK", 0.2)
    release = threading.Event()
    errors = []

    def stuck(scheme, options, timeout):
        release.wait(HANG_GUARD_MS / 1000)
        return list(TOPICS)

    try:
        dialog = LiveTopicDialog(None, lister=stuck, environ={}, timeout=0.1)
        qtbot.addWidget(dialog)
        dialog.message.connect(lambda text, error: errors.append((text, error)))
        with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
            dialog.show()
        assert errors == [("ROS 1 topics on http://localhost:11311: no answer within 0.3 s", True)]
        assert dialog.topic_names() == []
    finally:
        release.set()


def test_an_unreachable_master_is_one_line_in_the_message_area(make_gui, qtbot, monkeypatch):
    master = f"http://127.0.0.1:{ros1_env.free_port()}"  # nothing listens there: refused at once, on loopback
    monkeypatch.setenv("ROS_MASTER_URI", master)
    gui = make_gui(starting_system("hsv"), source="demo")
    gui.source_bar.kind.setCurrentText("topic")
    assert gui.source_bar.open_button.text() == "Open…"
    gui.source_bar.open_button.click()  # the source bar's way to the same dialog as File > Open topic
    dialog = gui.topic_dialog
    assert dialog is not None and dialog.isVisible()
    qtbot.waitUntil(lambda: dialog.status.text().startswith("ROS master"), timeout=HANG_GUARD_MS)
    line = dialog.status.text()
    assert line.startswith(f"ROS master at {master}/ does not answer (Connection refused): is roscore running")
    assert "\n" not in line
    assert gui.message_area.messages()[-1] == line
    assert dialog.topic_names() == [] and not dialog.open_button.isEnabled()
    dialog.reject()


def test_ros2_without_its_extra_says_which_to_install(make_gui, qtbot, monkeypatch):
    monkeypatch.setitem(sys.modules, "cyclonedds.core", None)  # as if cyclonedds were not installed
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    gui = make_gui(starting_system("hsv"), source="demo")
    dialog = gui.open_topic()
    with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
        dialog.set_transport("ros2")
    line = "ROS 2 topics on domain 0 cannot be listed: needs the ros2 extra: pip install 'objrec[ros2]'"
    assert dialog.status.text() == line
    assert gui.message_area.messages()[-1] == line
    dialog.reject()


# -- end to end: a real ROS 1 master and a rospy camera ------------------------------------------------------
PUBLISHER = r'''
import os
import sys
import rospy
from sensor_msgs.msg import Image

topic, width, height = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rospy.init_node("fake_camera")
publisher = rospy.Publisher(topic, Image, queue_size=1)
pixels = bytearray()
for y in range(height):
    for x in range(width):  # a red rectangle (BGR) on grey, clear of the borders
        red = width // 4 <= x < width // 2 and height // 4 <= y < 3 * height // 4
        pixels += bytes((0, 0, 220)) if red else bytes((90, 90, 90))
pixels = bytes(pixels)
print("ready", flush=True)
rate = rospy.Rate(15)
seq = 0
said = False
while not rospy.is_shutdown():
    message = Image(height=height, width=width, encoding="bgr8", is_bigendian=0, step=3 * width, data=pixels)
    message.header.seq = seq
    message.header.stamp = rospy.Time.now()
    message.header.frame_id = "camera_rgb_optical_frame"
    if not os.path.exists("quiet"):  # the test makes the camera go quiet with this file in the node's folder
        publisher.publish(message)
        said = False
    elif not said:
        print("quiet", flush=True)
        said = True
    seq += 1
    rate.sleep()
'''
WIDTH, HEIGHT = 96, 72  # not the demo's 640x480: the frames on screen must be the topic's


def test_the_dialog_offers_what_the_kinds_live_source_reads():
    reading = live_reading("2d", "ros1")
    assert reading.msgtypes == IMAGES
    assert reading.text == "images (sensor_msgs/Image or CompressedImage)"
    assert live_reading(None, "ros1") == LiveReading(None)  # no pipeline yet: every topic offered


def _choose_and_show(gui, dialog, qtbot, topic: str, spec: str, frames: int = 3) -> tuple[list, Any]:
    """Choose ``topic`` in the open dialog: the source it makes is ``spec`` and ``frames`` of its frames reach the
    screen. Returns the results shown (the list goes on growing while the topic plays) and the newest of ``spec``."""
    shown: list = []
    gui.frameShown.connect(lambda item: shown.append(item.results))
    dialog.choose(topic)
    assert dialog.spec == spec
    qtbot.waitUntil(lambda: sum(r.frame.source == spec for r in shown) >= frames, timeout=HANG_GUARD_MS)
    return shown, next(r for r in reversed(shown) if r.frame.source == spec)


def test_tuning_on_a_live_ros1_topic(ros1_master, make_gui, qtbot, tmp_path):
    node = RospyNode.start(PUBLISHER, ros1_master, tmp_path / "nodes", args=["/camera/rgb/image_raw", str(WIDTH),
                                                                             str(HEIGHT)], name="fake_camera")
    try:
        assert node.wait_for("ready", timeout=STARTUP_DEADLINE) is not None, node.diagnostics()
        gui = make_gui(starting_system("hsv"), source="demo")
        dialog = gui.open_topic()
        assert dialog.master.text() == ros1_master.uri  # ROS_MASTER_URI, prefilled
        rows = []

        def listed_camera() -> bool:  # the node registers its topics just after it says ready: list again
            rows[:] = dialog.topic_names()
            if not any(name == "/camera/rgb/image_raw" for name, _type, _ok in rows):
                with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
                    dialog.refresh()
                return False
            return True

        qtbot.waitUntil(listed_camera, timeout=HANG_GUARD_MS)
        assert ("/camera/rgb/image_raw", "sensor_msgs/msg/Image", True) in rows
        assert ("/rosout", "rosgraph_msgs/msg/Log", False) in rows  # rospy's log topic: greyed for images

        spec = f"ros1:/camera/rgb/image_raw,master={ros1_master.uri}"
        shown, results = _choose_and_show(gui, dialog, qtbot, "/camera/rgb/image_raw", spec)
        assert results.frame.data.shape == (HEIGHT, WIDTH, 3)
        assert results.frame.frame_id == "camera_rgb_optical_frame"
        assert results.frame.data[HEIGHT // 2, WIDTH // 4 + 1].tolist() == [0, 0, 220]
        assert results.frame.data[0, 0].tolist() == [90, 90, 90]
        qtbot.waitUntil(lambda: gui.stage_views.results is not None
                        and gui.stage_views.results.frame.source == spec, timeout=HANG_GUARD_MS)
        sizes = {key: view.image_size() for key, view in gui.stage_views.views.items()}
        assert sizes and set(sizes.values()) == {(WIDTH, HEIGHT)}  # every stage view shows the topic's frames
        assert len(results.objects.objects) == 1  # the red rectangle, found
        assert gui.seek_bar.isHidden()
        assert gui.source_bar.kind.currentText() == "topic"
        assert " received " in gui.source_bar.fps_label.text()

        quiet = tmp_path / "nodes" / "quiet"
        quiet.touch()  # the camera pauses, so the worker waits for its next frame...
        assert node.wait_for("quiet", timeout=STARTUP_DEADLINE) is not None, node.diagnostics()
        source, received = gui.worker.source, -1
        while source.received != received:  # a message rospy had queued may still come: wait it out
            received = source.received
            time.sleep(0.5)
        qtbot.waitUntil(lambda: source.frames + source.dropped + source.skipped == source.received
                        and shown[-1].frame.index == source.frames - 1, timeout=HANG_GUARD_MS)
        time.sleep(0.3)  # past the worker's pacing (30 frames/s): it now waits inside the live source
        missing = tmp_path / "missing.png"
        gui.open_source(str(missing))  # ...and is interrupted for a source that cannot be opened
        failure = f"{missing}: no such file"  # not "Opening …missing.png…", which comes first
        qtbot.waitUntil(lambda: any(text.startswith(failure) for text in gui.message_area.messages()),
                        timeout=HANG_GUARD_MS)
        count = len(shown)
        quiet.unlink()
        qtbot.waitUntil(lambda: len(shown) >= count + 3, timeout=HANG_GUARD_MS)  # the live topic plays on
        assert shown[-1].frame.source == spec and not gui.worker.ended
        assert not any("ended" in text for text in gui.message_area.messages())

        node.stop()  # the camera goes quiet: opening a recording must not wait for its next frame
        folder = write_folder(tmp_path / "shots", 3)
        gui.open_source(str(folder))
        qtbot.waitUntil(lambda: gui.seek_bar.isVisible() and shown[-1].frame.source.startswith(str(folder)),
                        timeout=HANG_GUARD_MS)
        assert shown[-1].frame.data.shape == (48, 64, 3)
        assert gui.seek_bar.slider.maximum() == 2
        assert not any("ended" in text for text in gui.message_area.messages()[-3:])
    finally:
        node.stop()


def test_tuning_on_a_ros2_topic(dds_env, make_gui, qtbot):
    """A camera on a ROS 2 domain (objrec's own DDS publisher, best effort as a ROS 2 camera driver sends):
    listed, opened, and its frames on screen."""
    from objrec_ros.live import open_transport
    from objrec_ros.msgdefs import standard_typestore
    from tests.ros.bagmaker import Messages

    pixels = np.full((HEIGHT, WIDTH, 3), 90, np.uint8)
    pixels[HEIGHT // 4:3 * HEIGHT // 4, WIDTH // 4:WIDTH // 2] = (0, 0, 220)
    maker = Messages("ros2")
    gui = make_gui(starting_system("hsv"), source="demo")
    sending = threading.Event()
    with open_transport("ros2", dds_env.options, node_name="camera") as camera:
        publisher = camera.advertise("/camera/color/image_raw", "sensor_msgs/msg/Image", standard_typestore(2),
                                     reliable=False)

        def send() -> None:  # about 15 frames/s until the test ends
            while not sending.wait(1 / 15):
                image = maker.image(pixels, "bgr8", time.time_ns(), "camera_color_optical_frame")
                publisher.publish(bytes(maker.serialize(image, "sensor_msgs/msg/Image")))

        sender = threading.Thread(target=send, name="ros2-camera", daemon=True)
        sender.start()
        try:
            dialog = gui.open_topic()
            assert dialog.domain.value() == dds_env.domain  # ROS_DOMAIN_ID, prefilled
            rows = []

            def listed_camera() -> bool:  # DDS discovery takes a moment: list again until it is seen
                with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
                    dialog.set_transport("ros2") if dialog.scheme != "ros2" else dialog.refresh()
                rows[:] = dialog.topic_names()
                return ("/camera/color/image_raw", "sensor_msgs/msg/Image", True) in rows

            qtbot.waitUntil(listed_camera, timeout=HANG_GUARD_MS)
            spec = f"ros2:/camera/color/image_raw,domain={dds_env.domain}"
            _, results = _choose_and_show(gui, dialog, qtbot, "/camera/color/image_raw", spec)
            assert np.array_equal(results.frame.data, pixels)
            assert results.frame.frame_id == "camera_color_optical_frame"
            assert len(results.objects.objects) == 1
            assert gui.seek_bar.isHidden() and gui.source_bar.kind.currentText() == "topic"
        finally:
            sending.set()
            sender.join(timeout=60)


def test_a_3d_pipeline_tunes_on_a_live_cloud(dds_env, make_gui, qtbot):
    """PointCloud2 on a ROS 2 domain feeds a 3D pipeline: its points in the cloud view, and the seek bar, shown
    for the demo of one frame, hidden for the topic."""
    from objrec_ros.live import open_transport
    from objrec_ros.msgdefs import standard_typestore
    from tests.ros.bagmaker import Messages

    rng = np.random.default_rng(7)
    points = rng.uniform((-0.5, -0.4, 0.8), (0.5, 0.4, 1.6), (1500, 3)).astype(np.float32)
    maker = Messages("ros2")
    gui = make_gui(starting_system("shape"), source="demo:frames=1")
    sending = threading.Event()
    with open_transport("ros2", dds_env.options, node_name="depth_camera") as camera:
        store = standard_typestore(2)
        clouds = camera.advertise("/camera/depth/points", "sensor_msgs/msg/PointCloud2", store, reliable=False)
        camera.advertise("/camera/color/image_raw", "sensor_msgs/msg/Image", store, reliable=False)

        def send() -> None:  # about 10 clouds/s until the test ends
            while not sending.wait(0.1):
                cloud = maker.cloud(points, None, time.time_ns(), "camera_depth_optical_frame")
                clouds.publish(bytes(maker.serialize(cloud, "sensor_msgs/msg/PointCloud2")))

        sender = threading.Thread(target=send, name="ros2-depth-camera", daemon=True)
        sender.start()
        try:
            assert not gui.seek_bar.isHidden()  # demo:frames=1 has an end
            dialog = gui.open_topic()
            rows = []

            def listed_both() -> bool:  # DDS discovery takes a moment: list again until both are seen
                with qtbot.waitSignal(dialog.listed, timeout=HANG_GUARD_MS):
                    dialog.set_transport("ros2") if dialog.scheme != "ros2" else dialog.refresh()
                rows[:] = dialog.topic_names()
                return len(rows) == 2

            qtbot.waitUntil(listed_both, timeout=HANG_GUARD_MS)
            # a 3D pipeline reads Image topics too (depth images with their CameraInfo): offered, not greyed
            assert rows == [("/camera/color/image_raw", "sensor_msgs/msg/Image", True),
                            ("/camera/depth/points", "sensor_msgs/msg/PointCloud2", True)]
            spec = f"ros2:/camera/depth/points,domain={dds_env.domain}"
            _, results = _choose_and_show(gui, dialog, qtbot, "/camera/depth/points", spec, frames=2)
            assert np.array_equal(results.frame.data.points.reshape(-1, 3), points)
            assert results.frame.frame_id == "camera_depth_optical_frame"
            assert gui.central.currentWidget() is gui.view3d
            assert gui.seek_bar.isHidden()
        finally:
            sending.set()
            sender.join(timeout=60)
