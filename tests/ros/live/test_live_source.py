"""The kinds' live sources on the in-process test transport: decoding, newest wins, deadlines, stop, bad specs."""

from __future__ import annotations

import logging
import subprocess
import sys
import threading
import time
from typing import Any

import numpy as np
import pytest

from objrec_core import DetectionDirector, SourceError, build_system, open_source
from objrec_ros.live import source as live_source
from tests.ros.live import memory_transport
from tests.ros.live.memory_transport import MemoryBus, MemoryTransport

memory_bus = memory_transport.memory_bus  # the fixtures, used by name

#: A hang guard only: nothing here is timed, a wait that never ends fails after this.
HANG_GUARD = 60.0
STAMP = 1_700_000_000_123_456_789


def publisher(bus: MemoryBus, topic: str, msgtype: str, maker: Any, ros2: bool = False) -> Any:
    """A latched publisher (its last message reaches a subscriber that comes later, as in ROS 1)."""
    transport = (memory_transport.MemoryTransport2 if ros2 else MemoryTransport).open({}, "test_camera")
    return transport.advertise(topic, msgtype, maker.store, latch=True)


def send(pub: Any, maker: Any, message: Any) -> None:
    pub.publish(bytes(maker.serialize(message, pub.msgtype)))


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_images_arrive_as_the_bag_source_decodes_them_with_stamp_and_frame_id(memory_bus, bagmaker, demo_images,
                                                                               fmt):
    maker = bagmaker.Messages(fmt)
    scheme = "memory" if fmt == "ros1" else "memory2"
    picture = demo_images[0]
    pub = publisher(memory_bus, "/camera/rgb/image_raw", bagmaker.IMAGE, maker, ros2=fmt != "ros1")
    send(pub, maker, maker.image(picture[..., ::-1], "rgb8", STAMP, "camera_rgb_optical_frame"))
    with open_source(f"{scheme}:/camera/rgb/image_raw,timeout=5", "2d") as source:
        assert source.length is None and not source.seekable
        frames = iter(source)
        first = next(frames)
        send(pub, maker, maker.image(picture[:, :, 1], "mono8", STAMP + 33_000_000, "other"))
        second = next(frames)
    assert np.array_equal(first.data, picture)  # rgb8 made BGR, as from a bag
    assert (first.stamp_ns, first.frame_id, first.index) == (STAMP, "camera_rgb_optical_frame", 0)
    assert np.array_equal(second.data, picture[:, :, 1])
    assert (second.stamp_ns, second.frame_id, second.index) == (STAMP + 33_000_000, "other", 1)
    assert source.received == 2 and source.dropped == 0


def test_compressed_png_images_are_decoded_exactly(memory_bus, bagmaker, demo_images):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/camera/rgb/image_raw/compressed", bagmaker.COMPRESSED_IMAGE, maker)
    send(pub, maker, maker.compressed(demo_images[1], "png", STAMP))
    with open_source("memory:/camera/rgb/image_raw/compressed,timeout=5", "2d") as source:
        frame = next(iter(source))
    assert np.array_equal(frame.data, demo_images[1])
    assert frame.stamp_ns == STAMP


def test_the_newest_frame_wins_and_the_dropped_ones_are_counted(memory_bus, bagmaker, demo_images):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/cam", bagmaker.IMAGE, maker)
    small = demo_images[0][:8, :8]
    send(pub, maker, maker.image(small, "bgr8", STAMP))
    with open_source("memory:/cam,timeout=5", "2d") as source:
        frames = iter(source)
        assert next(frames).stamp_ns == STAMP
        for i in range(1, 11):  # ten while the pipeline is busy: only the last is kept
            send(pub, maker, maker.image(small, "bgr8", STAMP + i))
        assert next(frames).stamp_ns == STAMP + 10
        assert (source.received, source.dropped, source.frames) == (11, 9, 2)
        assert source.run_summary() == "memory:/cam,timeout=5: 11 messages received, 9 dropped (newest wins)"


def test_a_topic_nobody_publishes_ends_after_its_timeout_naming_the_spec_and_what_is_live(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    publisher(memory_bus, "/camera/other", bagmaker.IMAGE, maker)
    with pytest.raises(SourceError) as caught:
        open_source("memory:/camera/rgb/image_raw,timeout=0.3", "2d")
    message = str(caught.value)
    assert message.startswith("memory:/camera/rgb/image_raw,timeout=0.3: no images (sensor_msgs/Image or "
                              "CompressedImage): no publisher of /camera/rgb/image_raw within 0.3 s (live: ")
    assert "/camera/other (sensor_msgs/msg/Image)" in message
    assert "\n" not in message
    assert all(t.closed for t in memory_bus.transports if t.node_name != "test_camera")  # nothing left joined


def test_a_topic_published_but_silent_ends_after_its_timeout(memory_bus, bagmaker):
    publisher(memory_bus, "/cam", bagmaker.IMAGE, bagmaker.Messages("ros1"))
    with pytest.raises(SourceError, match=r"^memory:/cam,timeout=0.2: /cam is published \(sensor_msgs/msg/Image\) "
                                          r"but no message came within 0.2 s"):
        open_source("memory:/cam,timeout=0.2", "2d")


def test_a_topic_of_another_type_or_a_depth_topic_is_refused_for_images(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    cloud = publisher(memory_bus, "/points", bagmaker.POINT_CLOUD2, maker)
    send(cloud, maker, maker.cloud(np.zeros((2, 3)), None, STAMP))
    with pytest.raises(SourceError, match=r"topic /points holds sensor_msgs/msg/PointCloud2, which a 2d live "
                                          r"source cannot read as images \(sensor_msgs/Image or CompressedImage\)$"):
        open_source("memory:/points,timeout=2", "2d")
    depth = publisher(memory_bus, "/depth", bagmaker.IMAGE, maker)
    send(depth, maker, maker.image(np.ones((4, 4), np.uint16), "16UC1", STAMP))
    with pytest.raises(SourceError, match=r"/depth holds depth images \(16UC1\), which are 3D data"):
        open_source("memory:/depth,timeout=2", "2d")


@pytest.mark.parametrize(("spec", "expected"), [
    ("ros1:/cam,domain=3", "ros1:/cam,domain=3: option domain belongs to ros2: topics; ros1: takes "
                           "ros1:/TOPIC[,master=http://HOST:11311][,timeout=S]"),
    ("ros2:/cam,master=http://h:11311", "ros2:/cam,master=http://h:11311: option master belongs to ros1: topics; "
                                        "ros2: takes ros2:/TOPIC[,domain=N][,timeout=S]"),
    ("ros1:", "ros1:: no topic given (ros1:/TOPIC[,master=http://HOST:11311][,timeout=S])"),
    ("ros1:/cam,timeout=0", "ros1:/cam,timeout=0: option timeout='0' is invalid"),
    ("ros2:/cam,domain=300", "ros2:/cam,domain=300: option domain='300' is invalid"),
    ("ros1:/cam,rate=3", "ros1:/cam,rate=3: unknown option 'rate'"),
])
def test_bad_live_specs_are_one_line_before_anything_is_joined(spec, expected):
    with pytest.raises(SourceError) as caught:
        open_source(spec, "2d")
    assert str(caught.value).startswith(expected)
    assert "\n" not in str(caught.value)


def test_an_unreachable_master_is_one_line(memory_bus):
    with pytest.raises(SourceError, match=r"^memory:/cam,master=http://unreachable:1/: the master at "):
        open_source("memory:/cam,master=http://unreachable:1/", "2d")


def test_the_spec_options_reach_the_transport_and_relative_topics_are_global(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/cam", bagmaker.IMAGE, maker)
    send(pub, maker, maker.image(np.zeros((2, 2, 3), np.uint8), "bgr8", STAMP))
    with open_source("memory:cam,master=http://127.0.0.1:5/,timeout=5", "2d") as source:
        assert source.topic == "/cam"
        assert source.transport.options == {"master": "http://127.0.0.1:5/"}


def test_the_run_stop_event_ends_a_wait_for_the_next_frame(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/cam", bagmaker.IMAGE, maker)
    send(pub, maker, maker.image(np.zeros((2, 2, 3), np.uint8), "bgr8", STAMP))
    system = build_system("params/hsv_demo.yaml")
    stop = threading.Event()
    done = threading.Event()
    with open_source("memory:/cam,timeout=5", "2d") as source:
        director = DetectionDirector(system)
        runner = threading.Thread(target=lambda: (director.run_all(source, stop=stop), done.set()), daemon=True)
        runner.start()
        deadline = time.monotonic() + HANG_GUARD
        while director.stats.frames < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert director.stats.frames == 1  # the first frame went through; now the source waits for a second
        assert not done.is_set()
        stop.set()
        assert done.wait(HANG_GUARD)
    assert director.stats.stopped_by == "stop" and director.stats.frames == 1


def test_close_from_another_thread_ends_a_wait(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/cam", bagmaker.IMAGE, maker)
    send(pub, maker, maker.image(np.zeros((2, 2, 3), np.uint8), "bgr8", STAMP))
    source = open_source("memory:/cam,timeout=5", "2d")
    got: list[Any] = []
    reader = threading.Thread(target=lambda: got.extend(source), daemon=True)
    reader.start()
    deadline = time.monotonic() + HANG_GUARD
    while not got and time.monotonic() < deadline:
        time.sleep(0.01)
    source.close()
    reader.join(HANG_GUARD)
    assert not reader.is_alive() and len(got) == 1


def test_a_quiet_topic_is_logged_by_name(memory_bus, bagmaker, monkeypatch, caplog):
    monkeypatch.setattr(live_source, "QUIET_WARNING", 0.3)
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/cam", bagmaker.IMAGE, maker)
    send(pub, maker, maker.image(np.zeros((2, 2, 3), np.uint8), "bgr8", STAMP))
    stop = threading.Event()
    with caplog.at_level(logging.WARNING, logger="objrec_ros.live.source"), \
            open_source("memory:/cam,timeout=5", "2d") as source:
        source.watch_stop(stop)
        frames = iter(source)
        next(frames)
        threading.Thread(target=lambda: (_wait_for_warning(caplog), stop.set()), daemon=True).start()
        assert list(frames) == []
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings and warnings[0].startswith("memory:/cam,timeout=5: no message on /cam for ")


def _wait_for_warning(caplog: Any) -> None:
    deadline = time.monotonic() + HANG_GUARD
    while not any(r.levelno == logging.WARNING for r in caplog.records) and time.monotonic() < deadline:
        time.sleep(0.02)


def test_an_unreadable_message_mid_stream_is_skipped_and_counted(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/cam", bagmaker.IMAGE, maker)
    send(pub, maker, maker.image(np.zeros((2, 2, 3), np.uint8), "bgr8", STAMP))
    with open_source("memory:/cam,timeout=5", "2d") as source:
        frames = iter(source)
        next(frames)
        send(pub, maker, maker.image(np.zeros((2, 2, 3), np.uint8), "yuv422", STAMP + 1))
        pub.publish(b"\x01\x02")  # too short for any Image: replaces the one above (newest wins)
        time.sleep(0)
        assert source.next_frame(source._subscription.next(HANG_GUARD)) is None
        send(pub, maker, maker.image(np.full((2, 2, 3), 7, np.uint8), "bgr8", STAMP + 2))
        frame = next(frames)
    assert frame.stamp_ns == STAMP + 2 and frame.index == 1
    assert source.skipped == 1
    assert source.run_summary().endswith("1 dropped (newest wins), 1 unreadable")


# -- 3D ---------------------------------------------------------------------------------------------------------
def test_pointcloud2_clouds_arrive_as_from_a_bag(memory_bus, bagmaker, demo_clouds):
    maker = bagmaker.Messages("mcap")
    cloud = demo_clouds[0]
    pub = publisher(memory_bus, "/camera/depth/points", bagmaker.POINT_CLOUD2, maker, ros2=True)
    colors = cloud.colors if cloud.colors is not None else None
    send(pub, maker, maker.cloud(cloud.points.reshape(cloud.height, cloud.width, 3), colors, STAMP, "depth"))
    with open_source("memory2:/camera/depth/points,timeout=5", "3d") as source:
        frame = next(iter(source))
    assert (frame.data.width, frame.data.height) == (cloud.width, cloud.height)
    assert np.array_equal(frame.data.points, cloud.points, equal_nan=True)
    assert (frame.stamp_ns, frame.frame_id) == (STAMP, "depth")


def test_a_depth_topic_takes_its_camera_info_beside_it_and_the_nearest_colour(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    depth = publisher(memory_bus, "/camera/depth/image_raw", bagmaker.IMAGE, maker)
    info = publisher(memory_bus, "/camera/depth/camera_info", bagmaker.CAMERA_INFO, maker)
    color = publisher(memory_bus, "/camera/rgb/image_raw", bagmaker.IMAGE, maker)
    millimetres = np.full((4, 6), 2000, np.uint16)
    send(depth, maker, maker.image(millimetres, "16UC1", STAMP, "depth_frame"))
    send(info, maker, maker.camera_info(6, 4, 2.0, 2.0, 3.0, 2.0, STAMP))
    red = np.zeros((4, 6, 3), np.uint8)
    red[..., 0] = 255  # rgb8: red
    send(color, maker, maker.image(red, "rgb8", STAMP))
    with open_source("memory:/camera/depth/image_raw,color=/camera/rgb/image_raw,timeout=5", "3d") as source:
        assert (source.info_topic, source.color_topic) == ("/camera/depth/camera_info", "/camera/rgb/image_raw")
        frames = iter(source)
        first = next(frames)
        blue = np.zeros((4, 6, 3), np.uint8)
        blue[..., 2] = 255
        send(color, maker, maker.image(blue, "rgb8", STAMP + 100))
        send(info, maker, maker.camera_info(6, 4, 4.0, 4.0, 3.0, 2.0, STAMP + 100))
        send(depth, maker, maker.image(millimetres, "16UC1", STAMP + 90, "depth_frame"))
        second = next(frames)
    points = first.data.points.reshape(4, 6, 3)
    assert np.allclose(points[0, 0], [(0 - 3.0) * 2.0 / 2.0, (0 - 2.0) * 2.0 / 2.0, 2.0])
    assert np.allclose(second.data.points.reshape(4, 6, 3)[0, 0], [(0 - 3.0) * 2.0 / 4.0, (0 - 2.0) * 2.0 / 4.0, 2.0])
    assert np.array_equal(np.unique(first.data.colors.reshape(-1, 3), axis=0), [[255, 0, 0]])
    assert np.array_equal(np.unique(second.data.colors.reshape(-1, 3), axis=0), [[0, 0, 255]])  # 10 ns away
    assert (second.stamp_ns, second.frame_id) == (STAMP + 90, "depth_frame")


def test_a_depth_topic_without_camera_info_says_how_to_name_one(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    depth = publisher(memory_bus, "/camera/depth/image_raw", bagmaker.IMAGE, maker)
    send(depth, maker, maker.image(np.ones((4, 6), np.uint16), "16UC1", STAMP))
    with pytest.raises(SourceError) as caught:
        open_source("memory:/camera/depth/image_raw,timeout=0.3", "3d")
    message = str(caught.value)
    assert message.startswith("memory:/camera/depth/image_raw,timeout=0.3: depth topic /camera/depth/image_raw "
                              "needs its CameraInfo: no camera intrinsics (sensor_msgs/CameraInfo): no publisher "
                              "of /camera/depth/camera_info within ")
    assert message.endswith("give its CameraInfo topic with info=TOPIC")


def test_info_and_color_are_refused_beside_a_pointcloud2_topic(memory_bus, bagmaker):
    maker = bagmaker.Messages("ros1")
    pub = publisher(memory_bus, "/points", bagmaker.POINT_CLOUD2, maker)
    send(pub, maker, maker.cloud(np.zeros((2, 3)), None, STAMP))
    with pytest.raises(SourceError, match=r"info=/x goes with a depth image topic; /points holds PointCloud2"):
        open_source("memory:/points,info=/x,timeout=2", "3d")


def test_the_declarations_name_implementations_of_the_same_forms():
    from objrec2d.live_declaration import IMAGE_LIVE
    from objrec2d.live_source import ImageLiveSource
    from objrec3d.live_declaration import CLOUD_LIVE
    from objrec3d.live_source import CloudLiveSource

    assert IMAGE_LIVE.load() is ImageLiveSource  # load() checks kind, schemes, extensions and folders agree
    assert CLOUD_LIVE.load() is CloudLiveSource
    assert ImageLiveSource.usage() == "ros1:/TOPIC[,master=http://HOST:11311][,timeout=S] | " \
                                      "ros2:/TOPIC[,domain=N][,timeout=S]"


def test_a_file_run_loads_nothing_live(project_root):
    code = ("import sys\nfrom objrec_core import open_source\nwith open_source('demo:frames=1', '2d') as s:\n"
            "    list(s)\nprint(sorted(m for m in sys.modules if m.startswith(('objrec_ros', 'cyclonedds'))))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=project_root,
                          timeout=HANG_GUARD)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
