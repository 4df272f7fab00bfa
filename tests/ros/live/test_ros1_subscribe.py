"""objrec's ROS 1 subscriber against rospy publishers on a real master: the bytes rosbags deserializes carry
rospy's values; topics are listed with their types; a missing topic is one line; the newest message wins;
a publisher that dies and a new one on the same topic: messages resume."""

from __future__ import annotations

import logging
import time
from pathlib import Path

import pytest

from objrec_ros.live import LiveError, open_transport
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import ros1_env
from tests.ros.live.ros1_env import Ros1Master, RospyNode

ros1_master = ros1_env.ros1_master  # the fixture, used by name

#: Hang guard of every wait (generous: 2 cores shared by many test processes), never asserted as a time.
GUARD = 60.0

# Publishes sensor_msgs/Image frames: stamp.secs = BASE + k, data[i] = (i * 7 + k) % 256, until COUNT are sent
# (0: forever) at RATE Hz; with WAIT it waits for a subscriber before the first. queue_size 100: rospy keeps
# every message, so what is dropped is dropped on our side.
IMAGE_PUBLISHER = """
import sys, time
import rospy
from sensor_msgs.msg import Image
topic, base, count, rate, wait = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
rospy.init_node("image_pub", anonymous=True)
pub = rospy.Publisher(topic, Image, queue_size=100)
print("ready", rospy.get_name(), flush=True)
if wait == "wait":
    while pub.get_num_connections() == 0 and not rospy.is_shutdown():
        time.sleep(0.02)
    print("connected", flush=True)
k = 0
while not rospy.is_shutdown() and (count == 0 or k < count):
    img = Image()
    img.header.stamp = rospy.Time(base + k, 500)
    img.header.frame_id = "camera_rgb"
    img.height, img.width, img.encoding, img.is_bigendian, img.step = 6, 8, "rgb8", 0, 24
    img.data = bytes((i * 7 + k) % 256 for i in range(6 * 24))
    pub.publish(img)
    k += 1
    if rate > 0:
        rospy.sleep(1.0 / rate)
print("done", k, flush=True)
rospy.spin()
"""

CLOUD_PUBLISHER = """
import struct, sys, time
import rospy
from sensor_msgs.msg import PointCloud2, PointField
rospy.init_node("cloud_pub", anonymous=True)
pub = rospy.Publisher(sys.argv[1], PointCloud2, queue_size=10)
print("ready", flush=True)
k = 0
while not rospy.is_shutdown():
    cloud = PointCloud2()
    cloud.header.stamp = rospy.Time(700 + k, 0)
    cloud.header.frame_id = "camera_depth"
    cloud.height, cloud.width = 1, 5
    cloud.fields = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
                    PointField("z", 8, PointField.FLOAT32, 1)]
    cloud.is_bigendian, cloud.point_step, cloud.row_step, cloud.is_dense = False, 12, 60, True
    cloud.data = b"".join(struct.pack("<fff", i * 0.5, -i * 0.25, 1.0 + k) for i in range(5))
    pub.publish(cloud)
    k += 1
    rospy.sleep(0.05)
"""


def _expected_image_data(k: int) -> bytes:
    return bytes((i * 7 + k) % 256 for i in range(6 * 24))


def _start(script: str, master: Ros1Master, tmp_path: Path, name: str, *args: str) -> RospyNode:
    node = RospyNode.start(script, master, tmp_path, args=list(args), name=name)
    assert node.wait_for("ready", GUARD) is not None, node.diagnostics()
    return node


def _next(subscription, what: str):
    message = subscription.next(GUARD)
    assert message is not None, f"no {what} within the hang guard"
    return message


def test_image_from_rospy_deserializes_to_its_values(ros1_master: Ros1Master, tmp_path: Path) -> None:
    typestore = standard_typestore(1)
    with _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "pub", "/camera/rgb/image_raw", "100", "0", "20", "-"), \
            open_transport("ros1", {"master": ros1_master.uri}) as transport:
        subscription = transport.subscribe("/camera/rgb/image_raw", "sensor_msgs/msg/Image", typestore)
        assert subscription.wait_type(GUARD) == "sensor_msgs/msg/Image"
        message = _next(subscription, "image")
        assert message.topic == "/camera/rgb/image_raw"
        assert message.msgtype == "sensor_msgs/msg/Image"
        image = typestore.deserialize_ros1(message.raw, "sensor_msgs/msg/Image")
        k = image.header.stamp.sec - 100
        assert k >= 0
        assert image.header.stamp.nanosec == 500
        assert image.header.frame_id == "camera_rgb"
        assert (image.height, image.width, image.encoding, image.is_bigendian, image.step) == (6, 8, "rgb8", 0, 24)
        assert bytes(image.data) == _expected_image_data(k)
        # the next one is a later frame of the same stream
        later = typestore.deserialize_ros1(_next(subscription, "second image").raw, "sensor_msgs/msg/Image")
        assert later.header.stamp.sec > image.header.stamp.sec
        assert bytes(later.data) == _expected_image_data(later.header.stamp.sec - 100)


def test_point_cloud_without_a_type_given_learns_it_from_the_publisher(ros1_master: Ros1Master,
                                                                        tmp_path: Path) -> None:
    typestore = standard_typestore(1)
    with _start(CLOUD_PUBLISHER, ros1_master, tmp_path, "cloud", "/camera/depth/points"), \
            open_transport("ros1", {}) as transport:  # the master from ROS_MASTER_URI (set by the fixture)
        subscription = transport.subscribe("camera/depth/points")  # relative: resolved in the root namespace
        assert subscription.topic == "/camera/depth/points"
        assert subscription.wait_type(GUARD) == "sensor_msgs/msg/PointCloud2"
        message = _next(subscription, "cloud")
        assert message.msgtype == "sensor_msgs/msg/PointCloud2"
        assert "\nHeader header\n" in subscription.definition  # the publisher's (rospy's, with its comments)
        assert "MSG: sensor_msgs/PointField" in subscription.definition
        cloud = typestore.deserialize_ros1(message.raw, "sensor_msgs/msg/PointCloud2")
        k = cloud.header.stamp.sec - 700
        assert cloud.header.frame_id == "camera_depth"
        assert [(f.name, f.offset, f.datatype, f.count) for f in cloud.fields] == [
            ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)]
        assert (cloud.height, cloud.width, cloud.point_step, cloud.row_step, cloud.is_dense) == (1, 5, 12, 60, True)
        points = cloud.data.view("<f4").reshape(5, 3)
        assert points[:, 0].tolist() == [0.0, 0.5, 1.0, 1.5, 2.0]
        assert points[:, 1].tolist() == [0.0, -0.25, -0.5, -0.75, -1.0]
        assert points[:, 2].tolist() == [1.0 + k] * 5


def test_topics_lists_the_rospy_topic_with_its_type(ros1_master: Ros1Master, tmp_path: Path) -> None:
    with _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "pub", "/camera/image", "0", "0", "5", "-"), \
            open_transport("ros1", {"master": ros1_master.uri}) as transport:
        topics = {t.name: t.msgtype for t in transport.topics()}
        assert topics["/camera/image"] == "sensor_msgs/msg/Image"
        assert topics["/rosout"] == "rosgraph_msgs/msg/Log"
        assert list(topics) == sorted(topics)


def test_a_topic_that_never_appears_is_one_line_naming_it(ros1_master: Ros1Master, tmp_path: Path) -> None:
    with _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "pub", "/camera/image", "0", "0", "5", "-"), \
            open_transport("ros1", {"master": ros1_master.uri}) as transport:
        subscription = transport.subscribe("/camera/imgae")
        with pytest.raises(LiveError) as caught:
            subscription.wait_type(1.0)
        text = str(caught.value)
        assert "\n" not in text
        assert "topic /camera/imgae: no publisher within 1 s" in text
        assert "/camera/image (sensor_msgs/msg/Image)" in text
        assert subscription.next(0.1) is None
        assert subscription.received == 0


def test_a_topic_of_another_type_is_one_line_and_never_delivered(ros1_master: Ros1Master, tmp_path: Path,
                                                                 caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="objrec_ros.live.ros1")
    with _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "pub", "/camera/image", "0", "0", "20", "-"), \
            open_transport("ros1", {"master": ros1_master.uri}) as transport:
        subscription = transport.subscribe("/camera/image", "sensor_msgs/msg/PointCloud2")
        with pytest.raises(LiveError) as caught:
            subscription.wait_type(GUARD)
        assert str(caught.value) == ("topic /camera/image has type sensor_msgs/msg/Image, not "
                                     "sensor_msgs/msg/PointCloud2")
        assert subscription.next(0.5) is None
    assert subscription.received == 0
    # rospy's publisher checks our md5sum and says why it refuses
    assert "of /camera/image refused us: topic types do not match: [sensor_msgs/PointCloud2] vs. " \
        "[sensor_msgs/Image]" in caplog.text


def test_newest_message_wins_and_the_counts_add_up(ros1_master: Ros1Master, tmp_path: Path) -> None:
    typestore = standard_typestore(1)
    with open_transport("ros1", {"master": ros1_master.uri}) as transport:
        subscription = transport.subscribe("/burst", "sensor_msgs/msg/Image", typestore)
        # 50 as fast as rospy sends them, once we are connected
        with _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "burst", "/burst", "0", "50", "0", "wait") as node:
            assert node.wait_for("done", GUARD) == "done 50", node.diagnostics()
            taken: list[int] = []
            while subscription.received < 50 or taken == [] or taken[-1] != 49:
                message = _next(subscription, "burst message")
                taken.append(typestore.deserialize_ros1(message.raw, "sensor_msgs/msg/Image").header.stamp.sec)
                time.sleep(0.2)  # a slow consumer: the publisher's burst overtakes it
            assert subscription.next(0.5) is None  # nothing left: the slot held one message
        assert subscription.received == 50  # TCP lost nothing: every message arrived ...
        assert len(taken) + subscription.dropped == subscription.received  # ... and was taken or dropped
        assert subscription.dropped > 0
        assert taken == sorted(taken) and len(set(taken)) == len(taken)
        assert taken[-1] == 49  # the newest won


def test_messages_resume_from_a_new_publisher_after_one_dies(ros1_master: Ros1Master, tmp_path: Path) -> None:
    typestore = standard_typestore(1)

    def stamp(subscription) -> int:
        return typestore.deserialize_ros1(_next(subscription, "image").raw, "sensor_msgs/msg/Image").header.stamp.sec

    with open_transport("ros1", {"master": ros1_master.uri}) as transport:
        subscription = transport.subscribe("/camera/image", "sensor_msgs/msg/Image", typestore)
        first = _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "first", "/camera/image", "1000", "0", "20", "-")
        try:
            assert 1000 <= stamp(subscription) < 2000
        finally:
            first.process.kill()  # no goodbye: the master still lists it, our link must keep trying
            first.stop()
        with _start(IMAGE_PUBLISHER, ros1_master, tmp_path, "second", "/camera/image", "2000", "0", "20", "-"):
            end = time.monotonic() + GUARD
            while (sec := stamp(subscription)) < 2000 and time.monotonic() < end:
                pass
            assert sec >= 2000
