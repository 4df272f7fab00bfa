"""What the ROS 1 transport says when it cannot: an unreachable master, a malformed master URI, a topic or
node name ROS 1 refuses, a malformed connection header; each one line. No ROS installation needed."""

from __future__ import annotations

import contextlib
import http.server
import socket
import threading
import xmlrpc.client

import pytest

from objrec_ros.live import LiveError, open_transport
from objrec_ros.live.ros1 import names, rpc, tcpros


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_an_unreachable_master_is_one_line_naming_it_and_what_to_check() -> None:
    uri = f"http://127.0.0.1:{_free_port()}/"
    with pytest.raises(LiveError) as caught:
        open_transport("ros1", {"master": uri})
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith(f"ROS master at {uri} does not answer (Connection refused)")
    assert "roscore" in text and "ROS_MASTER_URI" in text and "ROS_IP" in text


def test_the_master_uri_comes_from_the_environment_when_no_option_gives_it(monkeypatch: pytest.MonkeyPatch) -> None:
    uri = f"http://127.0.0.1:{_free_port()}"
    monkeypatch.setenv("ROS_MASTER_URI", uri)
    with pytest.raises(LiveError, match=f"ROS master at {uri}/ does not answer"):
        open_transport("ros1")


@pytest.mark.parametrize(("master", "shown"), [("localhost:11311", "localhost:11311"),
                                               ("https://robot:11311", "https://robot:11311"),
                                               ("http://robot", "http://robot"),
                                               ("http://robot:port", "http://robot:port")])
def test_a_malformed_master_uri_is_one_line(master: str, shown: str) -> None:
    with pytest.raises(LiveError) as caught:
        open_transport("ros1", {"master": master})
    assert str(caught.value) == f"ROS master URI '{shown}' (option master) is not of the form http://HOST:PORT"


@pytest.mark.parametrize("topic", ["/camera//image", "/camera/image/", "/1camera", "/camera/im age", "",
                                   "~private", "/camera/\nimage"])
def test_a_topic_ros1_refuses_is_one_line_naming_it(topic: str) -> None:
    with pytest.raises(LiveError) as caught:
        names.topic_name(topic)
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith("topic '") and "is not a ROS 1 name" in text


def test_names_convert_between_ros1_and_rosbags() -> None:
    assert names.topic_name("camera/rgb/image_raw") == "/camera/rgb/image_raw"
    assert names.to_ros1_type("sensor_msgs/msg/Image") == "sensor_msgs/Image"
    assert names.to_ros1_type("sensor_msgs/Image") == "sensor_msgs/Image"
    assert names.from_ros1_type("sensor_msgs/Image") == "sensor_msgs/msg/Image"
    assert names.from_ros1_type("*") == "*"
    with pytest.raises(LiveError, match="message type 'Image' is not of the form package/msg/Type"):
        names.to_ros1_type("Image")
    first, second = names.caller_id("objrec"), names.caller_id("/objrec")
    assert first != second and first.startswith("/objrec_") and second.startswith("/objrec_")
    with pytest.raises(LiveError, match="node name 'my node' is not a ROS 1 base name"):
        names.caller_id("my node")


def test_connection_headers_round_trip_and_malformed_ones_are_refused() -> None:
    fields = {"callerid": "/objrec_1_1", "topic": "/camera/image", "md5sum": "*", "message_definition": "a=b\n"}
    wire = tcpros.encode_header(fields)
    assert int.from_bytes(wire[:4], "little") == len(wire) - 4
    assert tcpros.decode_header(wire[4:], "test") == fields  # '=' inside a value stays in the value
    with pytest.raises(tcpros.TcprosError, match="test: connection header field of 100 bytes runs past"):
        tcpros.decode_header((100).to_bytes(4, "little") + b"a=b", "test")
    with pytest.raises(tcpros.TcprosError, match="test: connection header field without '='"):
        tcpros.decode_header((3).to_bytes(4, "little") + b"abc", "test")
    with pytest.raises(tcpros.TcprosError, match="test: connection header cut inside a field length"):
        tcpros.decode_header(b"\x01\x00", "test")


class _HugeAnswers(http.server.BaseHTTPRequestHandler):
    """An XML-RPC peer whose answer claims a terabyte, or streams without end with no length."""

    def do_POST(self) -> None:
        self.rfile.read(int(self.headers["content-length"]))
        self.send_response(200)
        self.send_header("Content-Type", "text/xml")
        if self.path == "/claims":
            self.send_header("Content-Length", str(10**12))
            self.end_headers()
            return
        self.end_headers()
        chunk = b"<!-- " + b"x" * 65536 + b" -->"
        with contextlib.suppress(OSError):
            self.wfile.write(b"<?xml version='1.0'?><methodResponse>")
            for _ in range(1000):  # 65 MB if nobody stops reading
                self.wfile.write(chunk)

    def log_message(self, *_args: object) -> None:
        pass


@pytest.mark.parametrize("path", ["/claims", "/streams"])
def test_an_oversized_xmlrpc_answer_is_refused(path: str) -> None:
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _HugeAnswers)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        with pytest.raises(xmlrpc.client.ProtocolError, match="answer over 16,777,216 bytes"):
            rpc.call(f"http://127.0.0.1:{server.server_address[1]}{path}", "getPid", "/test", timeout=30)
    finally:
        server.shutdown()
        server.server_close()
