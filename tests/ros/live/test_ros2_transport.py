"""The ros2 transport in one process, on a DDS domain of the test's own confined to loopback.

Two transports (two DDS participants, as two nodes would be) publish and subscribe: the bytes that arrive
are rosbags' CDR bytes as published; the newest message wins with the replaced ones counted; a topic
nobody publishes ends in one LiveError naming it and what is live; closing lets go of the sockets. Waits
poll with generous deadlines (hang guards); nothing asserts wall-clock time.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from objrec_ros.live import TRANSPORTS, LiveError, open_transport
from objrec_ros.live.ros2 import NEEDS_EXTRA, Ros2Transport
from objrec_ros.live.ros2.transport import domain_of
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out

dds_env = dds.dds_env  # the fixture, used by name

HANG_GUARD = 30.0


def _until(condition: Callable[[], object], what: str, timeout: float = HANG_GUARD) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:g} s")
        time.sleep(0.02)


@pytest.fixture
def store():
    return standard_typestore(2)


def _image(store, stamp: int, pixels: int = 17):
    t = store.types
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=stamp, nanosec=123), frame_id="cam")
    return t["sensor_msgs/msg/Image"](header=header, height=1, width=pixels, encoding="mono8", is_bigendian=0,
                                      step=pixels, data=(np.arange(pixels) * 7 % 256).astype(np.uint8))


def _string(store, text: str) -> bytes:
    return bytes(store.serialize_cdr(store.types["std_msgs/msg/String"](data=text), "std_msgs/msg/String"))


def test_the_ros2_scheme_is_the_registered_transport() -> None:
    assert TRANSPORTS.get("ros2") is Ros2Transport
    assert (Ros2Transport.scheme, Ros2Transport.ros_version) == ("ros2", 2)


def test_published_bytes_arrive_as_rosbags_serialized_them(dds_env, store) -> None:
    # 17 pixels: a payload of 65 bytes, padded to 68 on the wire and unpadded on arrival.
    raw = bytes(store.serialize_cdr(_image(store, 1_700_000_000), "sensor_msgs/msg/Image"))
    assert len(raw) % 4 == 1
    with open_transport("ros2", dds_env.options, "camera") as camera, \
            open_transport("ros2", dds_env.options, "objrec") as objrec:
        publisher = camera.advertise("/camera/image_raw", "sensor_msgs/msg/Image", store, reliable=False)
        subscription = objrec.subscribe("camera/image_raw")  # relative: the root namespace
        assert subscription.wait_type(HANG_GUARD) == "sensor_msgs/msg/Image"
        _until(lambda: publisher.subscribers == 1, "the subscriber matched")
        message = None
        for _ in range(200):  # best effort: publish until one arrives
            publisher.publish(raw)
            message = subscription.next(0.1)
            if message is not None:
                break
        assert message is not None
        assert (message.topic, message.msgtype) == ("/camera/image_raw", "sensor_msgs/msg/Image")
        assert message.raw == raw
        decoded = store.deserialize_cdr(message.raw, "sensor_msgs/msg/Image")
        assert decoded.header.stamp.sec == 1_700_000_000 and decoded.data.tolist() == _image(store, 0).data.tolist()
        listed = objrec.topics(0.2)
        assert [(t.name, t.msgtype) for t in listed] == [("/camera/image_raw", "sensor_msgs/msg/Image")]


def test_the_newest_message_wins_and_the_replaced_ones_are_counted(dds_env, store) -> None:
    with open_transport("ros2", dds_env.options, "talker") as talker, \
            open_transport("ros2", dds_env.options, "listener") as listener:
        publisher = talker.advertise("/chatter", "std_msgs/msg/String", store)
        subscription = listener.subscribe("/chatter", "std_msgs/msg/String", store, reliable=True)
        _until(lambda: publisher.subscribers == 1, "the reliable subscriber matched")
        for i in range(5):
            publisher.publish(_string(store, f"message {i}"))
        _until(lambda: subscription.received == 5, "five reliable messages arrived")
        message = subscription.next(0)
        assert message is not None
        assert store.deserialize_cdr(message.raw, "std_msgs/msg/String").data == "message 4"
        assert (subscription.received, subscription.dropped) == (5, 4)
        assert subscription.next(0.05) is None
        publisher.publish(_string(store, "message 5"))
        message = subscription.next(HANG_GUARD)
        assert message is not None and store.deserialize_cdr(message.raw, "std_msgs/msg/String").data == "message 5"
        assert (subscription.received, subscription.dropped) == (6, 4)


def test_a_topic_nobody_publishes_ends_in_one_line_naming_what_is_live(dds_env, store) -> None:
    with open_transport("ros2", dds_env.options, "other") as other, \
            open_transport("ros2", dds_env.options) as objrec:
        other.advertise("/scan", "std_msgs/msg/String", store)
        _until(lambda: objrec.topics(0) != [], "the other node's topic discovered")
        subscription = objrec.subscribe("/camera/image_raw")
        with pytest.raises(LiveError) as caught:
            subscription.wait_type(0.5)
        assert str(caught.value) == (f"ros2: no publisher of /camera/image_raw appeared within 0.5 s on domain "
                                     f"{dds_env.domain}; live topics: /scan (std_msgs/msg/String)")
        assert subscription.next(0.1) is None


def test_a_typed_subscription_waits_for_a_publisher_of_its_type(dds_env, store) -> None:
    with open_transport("ros2", dds_env.options, "camera") as camera, open_transport("ros2", dds_env.options) as objrec:
        camera.advertise("/camera/image_raw", "sensor_msgs/msg/CompressedImage", store)
        as_image = objrec.subscribe("/camera/image_raw", "sensor_msgs/msg/Image", store)
        with pytest.raises(LiveError) as caught:
            as_image.wait_type(HANG_GUARD)
        assert str(caught.value) == ("ros2: /camera/image_raw is published as sensor_msgs/msg/CompressedImage, "
                                     "not as sensor_msgs/msg/Image")
        as_compressed = objrec.subscribe("/camera/image_raw", "sensor_msgs/msg/CompressedImage", store)
        assert as_compressed.wait_type(HANG_GUARD) == "sensor_msgs/msg/CompressedImage"


def test_a_publisher_that_goes_away_and_comes_back_is_heard_again(dds_env, store) -> None:
    with open_transport("ros2", dds_env.options) as objrec:
        subscription = objrec.subscribe("/chatter", "std_msgs/msg/String", store, reliable=True)
        for run in range(2):
            with open_transport("ros2", dds_env.options, f"talker{run}") as talker:
                publisher = talker.advertise("/chatter", "std_msgs/msg/String", store)
                _until(lambda p=publisher: p.subscribers == 1, f"run {run}: matched")
                publisher.publish(_string(store, f"run {run}"))
                message = subscription.next(HANG_GUARD)
                assert message is not None
                assert store.deserialize_cdr(message.raw, "std_msgs/msg/String").data == f"run {run}"
        assert subscription.received == 2


@pytest.mark.parametrize("typed", [True, False])
def test_closing_wakes_a_reader_waiting_without_a_deadline(dds_env, store, typed: bool) -> None:
    """``next(None)`` waits as long as it takes; closing is the caller's way to stop it (typed or not)."""
    with open_transport("ros2", dds_env.options) as objrec:
        subscription = objrec.subscribe("/silent", "std_msgs/msg/String" if typed else None, store)
        results: list[object] = []
        waiter = threading.Thread(target=lambda: results.append(subscription.next(None)))
        waiter.start()
        time.sleep(0.2)
        assert waiter.is_alive()
        subscription.close()
        waiter.join(HANG_GUARD)
        assert not waiter.is_alive() and results == [None]


def test_subscribers_are_counted_from_matches(dds_env, store) -> None:
    with open_transport("ros2", dds_env.options, "a") as a, open_transport("ros2", dds_env.options, "b") as b:
        publisher = a.advertise("/detected_objects_2d", "std_msgs/msg/String", store)
        assert publisher.subscribers == 0
        subscription = b.subscribe("/detected_objects_2d", "std_msgs/msg/String", store, reliable=True)
        _until(lambda: publisher.subscribers == 1, "matched")
        subscription.close()
        subscription.close()  # idempotent
        _until(lambda: publisher.subscribers == 0, "unmatched after close")


def test_close_lets_go_of_every_socket_of_the_domain(dds_env, store) -> None:
    ports = {dds.discovery_port(dds_env.domain, i) + k for i in range(dds.MAX_PARTICIPANTS + 1) for k in (0, 1)}

    def domain_sockets() -> list[int]:
        return [port for _, port in dds.bound_udp_addresses(os.getpid()) if port in ports]

    transport = open_transport("ros2", dds_env.options)
    transport.advertise("/x", "std_msgs/msg/String", store)
    transport.subscribe("/y", "std_msgs/msg/String", store)
    assert len(domain_sockets()) == 2  # discovery and data, unicast (no multicast sockets)
    transport.close()
    transport.close()  # idempotent
    assert domain_sockets() == []
    with pytest.raises(LiveError, match=f"the transport on domain {dds_env.domain} is closed"):
        transport.subscribe("/y", "std_msgs/msg/String", store)


def test_bad_names_are_refused_before_anything_is_made(dds_env, store) -> None:
    with open_transport("ros2", dds_env.options) as transport:
        with pytest.raises(LiveError, match=r"topic '/camera//image' is not a valid ROS 2 name: it has a repeated"):
            transport.advertise("/camera//image", "std_msgs/msg/String", store)
        with pytest.raises(LiveError, match=r"type 'sensor_msgs/Image' is not a ROS 2 type name"):
            transport.subscribe("/camera/image", "sensor_msgs/Image", store)
        assert transport.topics(0) == []


@pytest.mark.parametrize(("options", "environ", "domain"), [
    ({}, {}, 0), ({}, {"ROS_DOMAIN_ID": "42"}, 42), ({"domain": "7"}, {"ROS_DOMAIN_ID": "42"}, 7),
    ({"domain": " 232 "}, {}, 232), ({}, {"ROS_DOMAIN_ID": ""}, 0),
])
def test_the_domain_comes_from_the_option_then_ros_domain_id(options, environ, domain) -> None:
    assert domain_of(options, environ) == domain


@pytest.mark.parametrize(("options", "environ", "message"), [
    ({"domain": "233"}, {}, "ros2: domain '233' is not a domain id (a whole number from 0 to 232)"),
    ({"domain": "one"}, {}, "ros2: domain 'one' is not a domain id (a whole number from 0 to 232)"),
    ({}, {"ROS_DOMAIN_ID": "-1"}, "ros2: ROS_DOMAIN_ID '-1' is not a domain id (a whole number from 0 to 232)"),
])
def test_a_bad_domain_is_one_line(options, environ, message) -> None:
    with pytest.raises(LiveError) as caught:
        domain_of(options, environ)
    assert str(caught.value) == message


def test_without_cyclonedds_opening_says_which_extra_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    for module in ("cyclonedds", "cyclonedds.core", "cyclonedds.domain"):
        monkeypatch.setitem(sys.modules, module, None)  # importing it now raises ImportError
    with pytest.raises(LiveError) as caught:
        open_transport("ros2", {"domain": "3"})
    assert str(caught.value) == NEEDS_EXTRA == "ros2: needs the ros2 extra: pip install 'objrec[ros2]'"
