"""The QoS objrec's readers and writers announce, as another participant on the domain discovers them.

What a ROS 2 peer matches on is what DDS discovery carries, so the policies are read back from the
DCPSPublication / DCPSSubscription builtin topics of a separate participant, not from objrec's objects:
sensor inputs best effort keep last 5, reliable inputs and detections reliable keep last 10 with a bounded
blocking time, latched outputs transient local keep last 1, never KEEP_ALL; XCDR1 on the wire; and ROS 2's
type-hash user data.
"""

from __future__ import annotations

import time

import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy

from objrec_ros.live import open_transport
from objrec_ros.live.ros2.entities import delete_entity
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out

dds_env = dds.dds_env  # the fixture, used by name

HANG_GUARD = 30.0
MS = 1_000_000


def _discovered(participant: DomainParticipant, count: int) -> dict[tuple[str, str], object]:
    """(kind, DDS topic) -> QoS of the first ``count`` rt/ endpoints another participant discovers."""
    readers = {"writer": BuiltinDataReader(participant, BuiltinTopicDcpsPublication),
               "reader": BuiltinDataReader(participant, BuiltinTopicDcpsSubscription)}
    found: dict[tuple[str, str], object] = {}
    deadline = time.monotonic() + HANG_GUARD
    while len(found) < count:
        assert time.monotonic() < deadline, f"only {sorted(found)} discovered"
        for kind, reader in readers.items():
            for endpoint in reader.take(64):
                if endpoint.topic_name.startswith("rt/"):
                    found[(kind, endpoint.topic_name)] = endpoint.qos
        time.sleep(0.02)
    for reader in readers.values():
        delete_entity(reader)
    return found


def test_peers_see_the_qos_a_ros2_user_expects(dds_env) -> None:
    store = standard_typestore(2)
    with open_transport("ros2", dds_env.options) as objrec:
        objrec.subscribe("/camera/color/image_raw", "sensor_msgs/msg/Image", store)
        objrec.subscribe("/camera/color/camera_info", "sensor_msgs/msg/CameraInfo", store, reliable=True)
        objrec.advertise("/detected_objects_2d", "std_msgs/msg/String", store)
        objrec.advertise("/objrec/map", "std_msgs/msg/String", store, latch=True)
        objrec.advertise("/objrec/preview", "sensor_msgs/msg/Image", store, reliable=False)
        peer = DomainParticipant(dds_env.domain)
        try:
            qos = _discovered(peer, 5)
        finally:
            delete_entity(peer)

    camera = qos[("reader", "rt/camera/color/image_raw")]
    assert camera[Policy.Reliability] == Policy.Reliability.BestEffort
    assert camera[Policy.History] == Policy.History.KeepLast(5)
    assert camera[Policy.Durability] == Policy.Durability.Volatile

    info = qos[("reader", "rt/camera/color/camera_info")]
    assert info[Policy.Reliability] == Policy.Reliability.Reliable(max_blocking_time=50 * MS)
    assert info[Policy.History] == Policy.History.KeepLast(10)

    detections = qos[("writer", "rt/detected_objects_2d")]
    assert detections[Policy.Reliability] == Policy.Reliability.Reliable(max_blocking_time=50 * MS)
    assert detections[Policy.History] == Policy.History.KeepLast(10)
    assert detections[Policy.Durability] == Policy.Durability.Volatile

    latched = qos[("writer", "rt/objrec/map")]
    assert latched[Policy.Durability] == Policy.Durability.TransientLocal
    assert latched[Policy.History] == Policy.History.KeepLast(1)

    preview = qos[("writer", "rt/objrec/preview")]
    assert preview[Policy.Reliability] == Policy.Reliability.BestEffort

    for (kind, topic), policies in qos.items():
        assert policies[Policy.History] != Policy.History.KeepAll, topic
        if kind == "writer":  # what is written is XCDR1, as ROS 2 writes and rosbags reads
            assert policies[Policy.DataRepresentation] == Policy.DataRepresentation(use_cdrv0_representation=True)
    msgtype = {"rt/camera/color/image_raw": "sensor_msgs/msg/Image", "rt/objrec/preview": "sensor_msgs/msg/Image",
               "rt/camera/color/camera_info": "sensor_msgs/msg/CameraInfo"}
    for (_, topic), policies in qos.items():
        expected = store.hash_rihs01(msgtype.get(topic, "std_msgs/msg/String"))
        assert expected.startswith("RIHS01_") and len(expected) == len("RIHS01_") + 64
        assert policies[Policy.Userdata] == Policy.Userdata(f"typehash={expected};".encode())
