"""The kinds' live sources on a real ROS 1 system: rospy nodes (Debian's system Python, child processes) publish,
``ros1:`` specs read. Frames equal what the bag sources read from the same messages; a publisher that goes away
and comes back is picked up again; a topic nobody publishes and a master nobody runs are one line each;
``--list-topics ros1:`` lists what rospy publishes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from objrec_core import SourceError, open_source
from tests.ros.live import ros1_env
from tests.ros.live.ros1_env import Ros1Master, RospyNode

ros1_master = ros1_env.ros1_master  # the fixtures, used by name

HANG_GUARD = 120.0
STAMP = 1_700_000_000_000_000_000

#: Publishes the messages in each FOLDER on its TOPIC, one of each per tick at RATE Hz, round and round.
PLAYER = r"""
import os, sys
import rospy
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, PointCloud2

classes = {"Image": Image, "CompressedImage": CompressedImage, "PointCloud2": PointCloud2, "CameraInfo": CameraInfo}
rate, rest = float(sys.argv[1]), sys.argv[2:]
rospy.init_node("player", anonymous=True, disable_signals=True)
streams = []
for topic, type_name, folder in zip(rest[0::3], rest[1::3], rest[2::3]):
    messages = []
    for name in sorted(os.listdir(folder)):
        message = classes[type_name]()
        message.deserialize(open(os.path.join(folder, name), "rb").read())
        messages.append(message)
    streams.append((rospy.Publisher(topic, classes[type_name], queue_size=1), messages))
print("ready", rospy.get_name(), flush=True)
tick = 0
while not rospy.is_shutdown():
    for publisher, messages in streams:
        publisher.publish(messages[tick % len(messages)])
    tick += 1
    rospy.sleep(1.0 / rate)
"""


def write_messages(folder: Path, maker: Any, messages: list[Any], msgtype: str) -> Path:
    folder.mkdir(parents=True)
    for index, message in enumerate(messages):
        (folder / f"{index:04d}.msg").write_bytes(bytes(maker.serialize(message, msgtype)))
    return folder


def player(master: Ros1Master, tmp_path: Path, streams: list[tuple[str, str, Path]], name: str,
           rate: float = 20.0) -> RospyNode:
    args = [str(rate)] + [str(part) for stream in streams for part in stream]
    node = RospyNode.start(PLAYER, master, tmp_path, args=args, name=name)
    assert node.wait_for("ready") is not None, node.diagnostics()
    return node


def test_images_of_every_kind_arrive_as_the_bag_source_reads_them(ros1_master, tmp_path, bagmaker,
                                                                  demo_images):
    maker = bagmaker.Messages("ros1")
    picture = demo_images[0]
    messages = {
        "bgr8": maker.image(picture, "bgr8", STAMP, "cam"),
        "rgb8_padded": maker.image(picture[..., ::-1], "rgb8", STAMP, "cam", pad=6),
        "mono16": maker.image(picture[..., 1].astype(np.uint16) << 8, "mono16", STAMP, "cam"),
    }
    streams = [(f"/camera/{name}", "Image", write_messages(tmp_path / name, maker, [m], bagmaker.IMAGE))
               for name, m in messages.items()]
    png = maker.compressed(picture, "png", STAMP, "cam")
    streams.append(("/camera/compressed", "CompressedImage",
                    write_messages(tmp_path / "png", maker, [png], bagmaker.COMPRESSED_IMAGE)))
    with player(ros1_master, tmp_path, streams, "images"):
        for topic, expected in (("/camera/bgr8", picture), ("/camera/rgb8_padded", picture),
                                ("/camera/mono16", picture[..., 1]), ("/camera/compressed", picture)):
            with open_source(f"ros1:{topic},timeout=60", "2d") as source:
                frame = next(iter(source))
                assert np.array_equal(frame.data, expected), topic
                assert (frame.stamp_ns, frame.frame_id) == (STAMP, "cam")


def test_a_depth_topic_with_camera_info_and_colour_equals_the_bag_source(ros1_master, tmp_path,
                                                                         bagmaker, demo_images):
    maker = bagmaker.Messages("ros1")
    rng = np.random.default_rng(5)
    depth = rng.integers(500, 3000, size=(480, 640), dtype=np.uint16)
    depth[:10] = 0  # no return: NaN points
    entries = [
        bagmaker.Entry("/camera/depth/image_raw", bagmaker.IMAGE, STAMP, maker.image(depth, "16UC1", STAMP, "d")),
        bagmaker.Entry("/camera/depth/camera_info", bagmaker.CAMERA_INFO, STAMP,
                       maker.camera_info(640, 480, 525.0, 525.0, 319.5, 239.5, STAMP, "d")),
        bagmaker.Entry("/camera/rgb/image_raw", bagmaker.IMAGE, STAMP, maker.image(demo_images[0], "bgr8", STAMP)),
    ]
    bag = bagmaker.write(tmp_path / "rgbd", "ros1", maker, entries)
    with open_source(f"bag:{bag},color_topic=/camera/rgb/image_raw", "3d") as source:
        recorded = next(iter(source))
    types = {bagmaker.IMAGE: "Image", bagmaker.CAMERA_INFO: "CameraInfo"}
    streams = [(e.topic, types[e.msgtype], write_messages(tmp_path / e.topic.replace("/", "_"), maker, [e.message],
                                                         e.msgtype)) for e in entries]
    with player(ros1_master, tmp_path, streams, "rgbd"), \
            open_source("ros1:/camera/depth/image_raw,color=/camera/rgb/image_raw,timeout=60", "3d") as source:
        assert source.info_topic == "/camera/depth/camera_info"  # beside the depth topic, as drivers name it
        live = next(iter(source))
    assert np.array_equal(live.data.points, recorded.data.points, equal_nan=True)
    assert np.array_equal(live.data.colors, recorded.data.colors)
    assert (live.stamp_ns, live.frame_id) == (recorded.stamp_ns, recorded.frame_id) == (STAMP, "d")


def test_a_publisher_that_goes_away_and_comes_back_is_picked_up_again(ros1_master, tmp_path,
                                                                      bagmaker, demo_images):
    maker = bagmaker.Messages("ros1")
    small = demo_images[0][:48, :64]
    first = write_messages(tmp_path / "first", maker, [maker.image(small, "bgr8", STAMP, "a")], bagmaker.IMAGE)
    second = write_messages(tmp_path / "second", maker, [maker.image(small, "bgr8", STAMP + 1, "b")], bagmaker.IMAGE)
    node = player(ros1_master, tmp_path, [("/camera/image", "Image", first)], "first")
    try:
        with open_source("ros1:/camera/image,timeout=60", "2d") as source:
            frames = iter(source)
            assert next(frames).frame_id == "a"
            node.stop()  # the camera goes away...
            with player(ros1_master, tmp_path, [("/camera/image", "Image", second)], "second"):  # ...comes back
                frame = next(frame for frame in frames if frame.frame_id == "b")
    finally:
        node.stop()
    assert frame.stamp_ns == STAMP + 1


def test_a_topic_nobody_publishes_names_what_is_live(ros1_master, tmp_path, bagmaker, demo_images):
    maker = bagmaker.Messages("ros1")
    folder = write_messages(tmp_path / "m", maker, [maker.image(demo_images[0][:4, :4], "bgr8", STAMP)],
                            bagmaker.IMAGE)
    with player(ros1_master, tmp_path, [("/camera/other", "Image", folder)], "other"), \
            pytest.raises(SourceError) as caught:
        open_source("ros1:/camera/rgb/image_raw,timeout=1", "2d")
    message = str(caught.value)
    assert message.startswith("ros1:/camera/rgb/image_raw,timeout=1: no images")
    assert "/camera/rgb/image_raw" in message and "/camera/other" in message and "\n" not in message


def test_a_master_nobody_runs_is_one_line():
    port = ros1_env.free_port()
    with pytest.raises(SourceError) as caught:
        open_source(f"ros1:/camera/image,master=http://127.0.0.1:{port}/,timeout=2", "2d")
    assert str(caught.value).startswith(f"ros1:/camera/image,master=http://127.0.0.1:{port}/,timeout=2: ")
    assert f"127.0.0.1:{port}" in str(caught.value).split(": ", 1)[1] and "\n" not in str(caught.value)


def test_list_topics_shows_what_rospy_publishes(ros1_master, tmp_path, bagmaker, demo_images, project_root):
    maker = bagmaker.Messages("ros1")
    folder = write_messages(tmp_path / "m", maker, [maker.image(demo_images[0][:4, :4], "bgr8", STAMP)],
                            bagmaker.IMAGE)
    with player(ros1_master, tmp_path, [("/camera/rgb/image_raw", "Image", folder)], "lister"):
        done = subprocess.run([sys.executable, "-m", "objrec_apps.detect", "--list-topics",
                               f"ros1:,master={ros1_master.uri}"], capture_output=True, text=True,
                              cwd=project_root, timeout=HANG_GUARD)
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines()]
    assert rows[0] == ["topic", "type"]
    assert ["/camera/rgb/image_raw", "sensor_msgs/msg/Image"] in rows
    assert done.stdout.splitlines()[-1].startswith(f"ros1 (master={ros1_master.uri}): ")
