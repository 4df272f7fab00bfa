"""objrec's ros2 transport and a plain cyclonedds program in another process understand each other.

The other process knows nothing of objrec or rosbags: it declares ``sensor_msgs::msg::dds_::Image_`` by
hand, as ROS 2's generated IDL spells it (``builtin_interfaces::msg::dds_::Time_`` and
``std_msgs::msg::dds_::Header_`` nested), on the DDS topic ``rt/...`` a ROS 2 node would use, with the QoS
a ROS 2 node uses by default. It stands in for a ROS 2 node (none can be installed here): an objrec
publisher is heard by it with every field equal, and objrec subscribes to what it publishes, finding the
type by discovery and receiving rosbags' CDR bytes of the same fields.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from objrec_ros.live import open_transport
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out

dds_env = dds.dds_env  # the fixture, used by name

HANG_GUARD = 60.0

#: A plain subscriber with rclcpp's default QoS (reliable, keep last 10): prints the first image's fields.
PLAIN_SUBSCRIBER = dds.ROS2_IMAGE_IDL + '''
import json, os
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

participant = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10))
reader = DataReader(participant, Topic(participant, "rt/objrec/image", Image), qos=qos)
print("ready", flush=True)
for s in reader.take_iter(timeout=duration(seconds=60)):
    print(json.dumps({"stamp": [s.header.stamp.sec, s.header.stamp.nanosec], "frame_id": s.header.frame_id,
                      "height": s.height, "width": s.width, "encoding": s.encoding,
                      "is_bigendian": s.is_bigendian, "step": s.step, "data": list(s.data)}), flush=True)
    break
'''

#: A plain publisher with rclcpp's default QoS: a 4 x 6 mono8 image every 50 ms, for at most a minute;
#: in XCDR1 as ROS 2 writes, or (XCDR=2 in its environment) XCDR2, as a DDS program might.
PLAIN_PUBLISHER = dds.ROS2_IMAGE_IDL + '''
import os, time
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.topic import Topic
from cyclonedds.util import duration

participant = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10),
          Policy.DataRepresentation(use_xcdrv2_representation=os.environ.get("XCDR") == "2",
                                    use_cdrv0_representation=os.environ.get("XCDR") != "2"))
writer = DataWriter(participant, Topic(participant, "rt/camera/image_raw", Image), qos=qos)
image = Image(Header(Time(1_700_000_321, 999_999_999), "camera_link"), 4, 6, "mono8", 0, 6,
              [(i * 37) % 256 for i in range(24)])
print("ready", flush=True)
for _ in range(1200):
    writer.write(image)
    time.sleep(0.05)
'''


@pytest.fixture
def run_child(dds_env):
    children: list[subprocess.Popen] = []

    def start(code: str, **env: str) -> subprocess.Popen:
        child = subprocess.Popen([sys.executable, "-c", code], env={**dds_env.env, **env}, stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)
        children.append(child)
        return child

    yield start
    for child in children:
        child.kill()
        child.wait(timeout=HANG_GUARD)


def test_a_plain_ros2_style_subscriber_hears_objrecs_image(dds_env, run_child) -> None:
    store = standard_typestore(2)
    t = store.types
    pixels = np.arange(3 * 4 * 3, dtype=np.uint8) * 5
    image = t["sensor_msgs/msg/Image"](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1_700_000_042, nanosec=17),
                                        frame_id="camera_color_optical_frame"),
        height=3, width=4, encoding="bgr8", is_bigendian=0, step=12, data=pixels)
    child = run_child(PLAIN_SUBSCRIBER)
    assert dds.child_line(child, HANG_GUARD, "the subscriber started") == "ready"
    with open_transport("ros2", dds_env.options) as objrec:
        publisher = objrec.advertise("/objrec/image", "sensor_msgs/msg/Image", store)  # reliable, keep last 10
        deadline = time.monotonic() + HANG_GUARD
        while publisher.subscribers < 1:
            assert time.monotonic() < deadline, "the plain subscriber never matched"
            time.sleep(0.02)
        publisher.publish(bytes(store.serialize_cdr(image, "sensor_msgs/msg/Image")))
        heard = json.loads(dds.child_line(child, HANG_GUARD, "the image heard"))
    assert heard == {"stamp": [1_700_000_042, 17], "frame_id": "camera_color_optical_frame", "height": 3,
                     "width": 4, "encoding": "bgr8", "is_bigendian": 0, "step": 12, "data": pixels.tolist()}


@pytest.mark.parametrize("xcdr", ["1", "2"])
def test_objrec_subscribes_to_a_plain_ros2_style_publisher(dds_env, run_child, xcdr: str) -> None:
    store = standard_typestore(2)
    child = run_child(PLAIN_PUBLISHER, XCDR=xcdr)
    assert dds.child_line(child, HANG_GUARD, "the publisher started") == "ready"
    with open_transport("ros2", dds_env.options) as objrec:
        subscription = objrec.subscribe("/camera/image_raw")  # sensor data QoS: best effort, keep last 5
        assert subscription.wait_type(HANG_GUARD) == "sensor_msgs/msg/Image"
        message = subscription.next(HANG_GUARD)
        assert message is not None
        image = store.deserialize_cdr(message.raw, "sensor_msgs/msg/Image")
        assert (image.header.stamp.sec, image.header.stamp.nanosec) == (1_700_000_321, 999_999_999)
        assert (image.header.frame_id, image.height, image.width, image.encoding, image.step) == (
            "camera_link", 4, 6, "mono8", 6)
        assert image.data.tolist() == [(i * 37) % 256 for i in range(24)]
        # The bytes are rosbags' CDR of the same fields (a payload of whole 4-byte words: no padding), also
        # when the writer sent XCDR2 (re-encoded on arrival).
        assert message.raw == bytes(store.serialize_cdr(image, "sensor_msgs/msg/Image"))
        assert message.raw[:4] == b"\x00\x01\x00\x00"
        assert [(t.name, t.msgtype) for t in objrec.topics(0)] == [("/camera/image_raw", "sensor_msgs/msg/Image")]
