"""objrec's ROS 1 publisher to rospy subscribers on a real master (rospy checks the md5sum and definition it
is sent), latching, and close() leaving nothing registered at the master."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from objrec_ros.live import LiveError, open_transport
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import ros1_env
from tests.ros.live.ros1_env import Ros1Master, RospyNode

ros1_master = ros1_env.ros1_master  # the fixture, used by name

GUARD = 60.0

# Prints one JSON line per Image received: what rospy deserialized with its own generated class.
IMAGE_SUBSCRIBER = """
import json, sys
import rospy
from sensor_msgs.msg import Image

def got(img):
    print(json.dumps({"sec": img.header.stamp.secs, "nsec": img.header.stamp.nsecs, "frame": img.header.frame_id,
                      "size": [img.height, img.width], "encoding": img.encoding, "step": img.step,
                      "bigendian": img.is_bigendian, "data": list(bytearray(img.data))}), flush=True)

rospy.init_node("image_sub", anonymous=True)
rospy.Subscriber(sys.argv[1], Image, got, queue_size=10)
print("ready", rospy.get_name(), flush=True)
rospy.spin()
"""


def _image(typestore, k: int):
    Image, Header, Time = (typestore.types[n] for n in  # noqa: N806 - message classes
                           ("sensor_msgs/msg/Image", "std_msgs/msg/Header", "builtin_interfaces/msg/Time"))
    data = np.array([(i * 3 + k) % 256 for i in range(4 * 6)], dtype=np.uint8)
    return Image(header=Header(seq=k, stamp=Time(sec=300 + k, nanosec=42), frame_id="objrec"),
                 height=2, width=4, encoding="mono8", is_bigendian=0, step=4 * 3, data=data)


def _received(node: RospyNode) -> dict:
    line = node.wait_for("{", GUARD)
    assert line is not None, node.diagnostics()
    return json.loads(line)


def test_rospy_subscriber_receives_our_image_with_its_values(ros1_master: Ros1Master, tmp_path: Path) -> None:
    typestore = standard_typestore(1)
    with open_transport("ros1", {"master": ros1_master.uri}) as transport:
        publisher = transport.advertise("/objrec/image", "sensor_msgs/msg/Image", typestore)
        assert publisher.subscribers == 0
        with RospyNode.start(IMAGE_SUBSCRIBER, ros1_master, tmp_path, args=["/objrec/image"], name="sub") as node:
            assert node.wait_for("ready", GUARD) is not None, node.diagnostics()
            end = time.monotonic() + GUARD
            while publisher.subscribers == 0 and time.monotonic() < end:
                time.sleep(0.02)
            assert publisher.subscribers == 1
            publisher.publish(typestore.serialize_ros1(_image(typestore, 5), "sensor_msgs/msg/Image"))
            got = _received(node)
    assert got == {"sec": 305, "nsec": 42, "frame": "objrec", "size": [2, 4], "encoding": "mono8", "step": 12,
                   "bigendian": 0, "data": [(i * 3 + 5) % 256 for i in range(24)]}


def test_a_latched_message_reaches_a_subscriber_that_comes_later(ros1_master: Ros1Master, tmp_path: Path) -> None:
    typestore = standard_typestore(1)
    with open_transport("ros1", {"master": ros1_master.uri}) as transport:
        publisher = transport.advertise("/objrec/latched", "sensor_msgs/msg/Image", typestore, latch=True)
        publisher.publish(typestore.serialize_ros1(_image(typestore, 1), "sensor_msgs/msg/Image"))
        publisher.publish(typestore.serialize_ros1(_image(typestore, 2), "sensor_msgs/msg/Image"))
        with RospyNode.start(IMAGE_SUBSCRIBER, ros1_master, tmp_path, args=["/objrec/latched"], name="sub") as node:
            assert _received(node)["sec"] == 302  # the last one published
            assert node.line(1.0) is None  # and only that one


def test_our_subscriber_reads_our_publisher(ros1_master: Ros1Master) -> None:
    typestore = standard_typestore(1)
    with open_transport("ros1", {"master": ros1_master.uri}, "camera") as camera, \
            open_transport("ros1", {"master": ros1_master.uri}, "detector") as detector:
        publisher = camera.advertise("/loop/image", "sensor_msgs/msg/Image", typestore)
        subscription = detector.subscribe("/loop/image")
        assert subscription.wait_type(GUARD) == "sensor_msgs/msg/Image"
        end = time.monotonic() + GUARD
        while publisher.subscribers == 0 and time.monotonic() < end:
            time.sleep(0.02)
        raw = typestore.serialize_ros1(_image(typestore, 9), "sensor_msgs/msg/Image")
        publisher.publish(raw)
        message = subscription.next(GUARD)
        assert message is not None and message.raw == raw


def test_close_unregisters_every_topic_at_the_master(ros1_master: Ros1Master) -> None:
    typestore = standard_typestore(1)
    transport = open_transport("ros1", {"master": ros1_master.uri}, "leaver")
    transport.advertise("/leaver/out", "sensor_msgs/msg/Image", typestore)
    transport.subscribe("/leaver/in", "sensor_msgs/msg/Image", typestore)
    transport.subscribe("/leaver/any")
    assert {node for node in ros1_master.nodes() if node.startswith("/leaver_")} == {transport.caller_id}
    publishers, subscribers, _services = ros1_master.system_state()
    assert ["/leaver/out", [transport.caller_id]] in publishers
    assert ["/leaver/in", [transport.caller_id]] in subscribers
    transport.close()
    assert not any(node.startswith("/leaver_") for node in ros1_master.nodes())
    transport.close()  # idempotent
    with pytest.raises(LiveError, match="is closed"):
        transport.subscribe("/leaver/in")


def test_a_type_the_typestore_does_not_know_is_one_line(ros1_master: Ros1Master) -> None:
    with open_transport("ros1", {"master": ros1_master.uri}) as transport, \
            pytest.raises(LiveError, match="message type my_msgs/msg/Thing is not known to the typestore"):
        transport.advertise("/thing", "my_msgs/msg/Thing", standard_typestore(1))


def test_a_ros_ip_not_of_this_host_is_one_line(ros1_master: Ros1Master, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_IP", "192.0.2.1")  # TEST-NET-1: never an address of this host; nothing is sent
    with open_transport("ros1", {"master": ros1_master.uri}) as transport, pytest.raises(LiveError) as caught:
        transport.subscribe("/camera/image")
    assert str(caught.value) == (f"ROS 1 node {transport.caller_id} cannot listen on 192.0.2.1 (Cannot assign "
                                 "requested address): is ROS_IP or ROS_HOSTNAME an address of this host?")
