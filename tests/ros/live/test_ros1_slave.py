"""Our node's Slave API as the master and ROS tools see it: found through lookupNode, it answers getPid,
getMasterUri, getPublications, getSubscriptions, getBusInfo and getBusStats, refuses requestTopic for a topic
it does not publish, and only logs a shutdown request (the application owns its lifetime)."""

from __future__ import annotations

import http.client
import logging
import os
import time
import xmlrpc.client
from urllib.parse import urlsplit

import pytest

from objrec_ros.live import open_transport
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import ros1_env
from tests.ros.live.ros1_env import Ros1Master

ros1_master = ros1_env.ros1_master  # the fixture, used by name

GUARD = 60.0


def test_the_slave_api_answers_what_rosnode_asks(ros1_master: Ros1Master, caplog: pytest.LogCaptureFixture) -> None:
    typestore = standard_typestore(1)
    with open_transport("ros1", {"master": ros1_master.uri}, "camera") as camera, \
            open_transport("ros1", {"master": ros1_master.uri}, "viewer") as viewer:
        publisher = camera.advertise("/cam/image", "sensor_msgs/msg/Image", typestore)
        subscription = viewer.subscribe("/cam/image", "sensor_msgs/msg/Image", typestore)
        end = time.monotonic() + GUARD
        while publisher.subscribers == 0 and time.monotonic() < end:
            time.sleep(0.02)
        assert publisher.subscribers == 1

        master = ros1_master.proxy()
        code, _message, camera_uri = master.lookupNode("/test", camera.caller_id)
        assert code == 1 and camera_uri.startswith("http://127.0.0.1:")
        code, _message, viewer_uri = master.lookupNode("/test", viewer.caller_id)
        assert code == 1
        camera_slave = xmlrpc.client.ServerProxy(camera_uri)
        viewer_slave = xmlrpc.client.ServerProxy(viewer_uri)

        assert camera_slave.getPid("/test") == [1, "pid", os.getpid()]
        assert camera_slave.getMasterUri("/test")[2] == ros1_master.uri
        assert camera_slave.getPublications("/test")[2] == [["/cam/image", "sensor_msgs/Image"]]
        assert viewer_slave.getSubscriptions("/test")[2] == [["/cam/image", "sensor_msgs/Image"]]

        [(connection_id, destination, direction, transport, topic, connected)] = camera_slave.getBusInfo("/test")[2]
        assert (destination, direction, transport, topic, connected) == (
            viewer.caller_id, "o", "TCPROS", "/cam/image", True)
        [(_, destination, direction, _, _, connected)] = viewer_slave.getBusInfo("/test")[2]
        assert (destination, direction, connected) == (camera_uri, "i", True)

        publisher.publish(b"\x00" * 40)  # not a valid Image, but bytes are bytes to the transport
        assert subscription.next(GUARD) is not None
        end = time.monotonic() + GUARD
        while camera_slave.getBusStats("/test")[2][0][0][1] < 44 and time.monotonic() < end:
            time.sleep(0.02)
        publish_stats, subscribe_stats, _services = camera_slave.getBusStats("/test")[2]
        assert publish_stats == [["/cam/image", 44, [[connection_id, 44, 1, True]]]]
        assert subscribe_stats == []
        viewer_stats = viewer_slave.getBusStats("/test")[2][1]
        assert viewer_stats[0][0] == "/cam/image" and viewer_stats[0][1][0][1:3] == [40, 1]

        code, message, _ = camera_slave.requestTopic("/test", "/other", [["TCPROS"]])
        assert code == -1 and "does not publish /other" in message
        code, message, _ = camera_slave.requestTopic("/test", "/cam/image", [["UDPROS"]])
        assert code == 0 and "TCPROS" in message

        with caplog.at_level(logging.WARNING, logger="objrec_ros.live.ros1"):
            assert camera_slave.shutdown("/rosnode", "kill")[0] == 1
        assert f"ROS node {camera.caller_id} was asked to shut down by /rosnode (kill)" in caplog.text
        publisher.publish(b"\x01" * 40)  # still serving
        message = subscription.next(GUARD)
        assert message is not None and message.raw == b"\x01" * 40


def test_the_slave_refuses_an_oversized_request(ros1_master: Ros1Master) -> None:
    with open_transport("ros1", {"master": ros1_master.uri}) as transport:
        transport.subscribe("/anything")  # the slave starts with the first subscription
        code, _message, uri = ros1_master.proxy().lookupNode("/test", transport.caller_id)
        assert code == 1
        parts = urlsplit(uri)
        connection = http.client.HTTPConnection(parts.hostname, parts.port, timeout=GUARD)
        try:
            connection.putrequest("POST", "/RPC2")
            connection.putheader("Content-Type", "text/xml")
            connection.putheader("Content-Length", str(4 * 1024**3))
            connection.endheaders()
            assert connection.getresponse().status == 413  # answered before a byte of the body is read
        finally:
            connection.close()
        assert xmlrpc.client.ServerProxy(uri).getPid("/test")[2] == os.getpid()  # and still serving
