"""objrec-detect with live topics on the in-process test transport: --publish, --publish-annotated,
--list-topics, the source's summary line, the deadlines and the stop signal."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from objrec2d.messages import DetectedObject2DArray
from objrec_apps.detect import main
from objrec_core import Header
from objrec_ros.encode import DetectionEncoder, PictureEncoder
from tests.ros.live import memory_transport
from tests.ros.live.memory_transport import MemoryBus, MemoryTransport, MemoryTransport2

memory_bus = memory_transport.memory_bus  # the fixture, used by name

HANG_GUARD = 120.0
STAMP = 1_700_000_000_000_000_000
FRAME_STEP = 33_333_333
CAMERA = "/camera/rgb/image_raw"


class Camera:
    """Publishes the demo images on CAMERA in lockstep with the detections: frame i+1 goes out once the
    detection of frame i was published on ``paced_by``, so none is dropped and the frames are known."""

    def __init__(self, bus: MemoryBus, maker: Any, images: list[np.ndarray], paced_by: str, frames: int) -> None:
        transport = MemoryTransport.open({}, "test_camera")
        self.publisher = transport.advertise(CAMERA, "sensor_msgs/msg/Image", maker.store, latch=True)
        self.bus, self.maker, self.images, self.paced_by, self.frames = bus, maker, images, paced_by, frames
        self.thread = threading.Thread(target=self._run, daemon=True)

    def image(self, index: int) -> np.ndarray:
        return self.images[index % len(self.images)]

    def _run(self) -> None:
        for index in range(self.frames):
            message = self.maker.image(self.image(index), "bgr8", STAMP + index * FRAME_STEP, "camera_rgb_frame")
            self.publisher.publish(bytes(self.maker.serialize(message, "sensor_msgs/msg/Image")))
            if len(self.bus.wait_sent(self.paced_by, index + 1, HANG_GUARD)) < index + 1:
                return

    def __enter__(self) -> Camera:
        self.thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.thread.join(HANG_GUARD)


def detect(argv: list[str], capsys: Any) -> tuple[int, str, str]:
    status = main(argv)
    out, err = capsys.readouterr()
    return status, out, err


def test_detections_are_published_as_the_bag_output_writes_them_stamped_like_their_frames(memory_bus, bagmaker,
                                                                                           demo_images, capsys):
    listeners = [MemoryTransport.open({}, "listener").subscribe("/detected"),
                 MemoryTransport2.open({}, "listener2").subscribe("/detected2")]
    with Camera(memory_bus, bagmaker.Messages("ros1"), demo_images, "/detected", 3):
        status, out, err = detect(["params/hsv_demo.yaml", "--source", f"memory:{CAMERA},timeout=10", "-n", "3",
                                   "--publish", "memory:/detected", "--publish", "memory2:/detected2"], capsys)
    assert status == 0, err
    lines = out.splitlines()
    assert len(lines) == 3
    for topic, version in (("/detected", 1), ("/detected2", 2)):
        sent = memory_bus.sent[topic]
        assert [m.msgtype for m in sent] == ["object_detection_2d_msgs/msg/DetectedObject2DArray"] * 3
        encoder = DetectionEncoder(DetectedObject2DArray, version)
        assert [m.raw for m in sent] == [encoder(DetectedObject2DArray.from_json(line)) for line in lines]
    arrays = [json.loads(line) for line in lines]
    assert [a["header"]["stamp"] for a in arrays] == [
        {"secs": 1_700_000_000, "nsecs": i * FRAME_STEP} for i in range(3)]
    assert {a["header"]["frame_id"] for a in arrays} == {"camera_rgb_frame"}
    assert all(len(a["objects"]) > 0 for a in arrays)  # the demo scene's coloured shapes
    assert f"objrec-detect: memory:{CAMERA},timeout=10: 3 messages received, 0 dropped (newest wins)\n" in err
    assert "objrec-detect: 3 messages published on memory:/detected to 1 subscriber\n" in err
    assert "objrec-detect: 3 messages published on memory2:/detected2 to 1 subscriber\n" in err
    assert all(listener.received == 3 for listener in listeners)


def test_the_annotated_picture_is_published_as_bgr8_like_the_annotate_output(memory_bus, bagmaker, demo_images,
                                                                             capsys, tmp_path):
    from rosbags.typesys import Stores, get_typestore

    MemoryTransport.open({}, "viewer").subscribe("/objrec/annotated")
    with Camera(memory_bus, bagmaker.Messages("ros1"), demo_images, "/objrec/annotated", 2):
        status, _, err = detect(["params/hsv_demo.yaml", "--source", f"memory:{CAMERA}", "-n", "2",
                                   "--publish-annotated", "memory:/objrec/annotated",
                                   "--annotate", str(tmp_path / "pictures")], capsys)
    assert status == 0, err
    store = get_typestore(Stores.ROS1_NOETIC)
    images = [store.deserialize_ros1(m.raw, m.msgtype) for m in memory_bus.sent["/objrec/annotated"]]
    written = sorted((tmp_path / "pictures").glob("*.png"))
    assert len(images) == len(written) == 2
    for index, (image, png) in enumerate(zip(images, written, strict=True)):
        assert (image.encoding, image.height, image.width, image.step) == ("bgr8", 480, 640, 640 * 3)
        assert (image.header.stamp.sec, image.header.stamp.nanosec) == (1_700_000_000, index * FRAME_STEP)
        assert image.header.frame_id == "camera_rgb_frame"
        assert np.array_equal(image.data.reshape(480, 640, 3), cv2.imread(str(png)))
    assert not np.array_equal(images[0].data.reshape(480, 640, 3), demo_images[0])  # something was drawn
    assert "objrec-detect: 2 annotated images published on memory:/objrec/annotated to 1 subscriber\n" in err


@pytest.mark.parametrize(("argv", "expected"), [
    (["--publish", "memory:/9bad"], "--publish memory:/9bad: not a valid ROS topic name"),
    (["--publish", "/detected"], "--publish /detected: not a live topic (ros1:/TOPIC[,master=URI] or "
                                 "ros2:/TOPIC[,domain=N])"),
    (["--publish", "memory:/x,timeout=3"], "--publish memory:/x,timeout=3: timeout= is for a live source"),
    (["--publish-annotated", "ros1:/x,domain=2"],
     "--publish-annotated ros1:/x,domain=2: option domain belongs to ros2: topics"),
])
def test_a_target_that_cannot_be_published_to_is_one_line_exit_2_before_any_frame(memory_bus, capsys, argv,
                                                                                  expected):
    status, out, err = detect(["params/hsv_demo.yaml", "--source", f"memory:{CAMERA},timeout=60", *argv], capsys)
    assert status == 2
    assert out == ""
    assert err.startswith(f"objrec-detect: error: {expected}") and err.count("\n") == 1
    assert CAMERA not in memory_bus.sent  # nobody published, and the run did not wait the source's 60 s for it


def test_a_master_that_does_not_answer_for_publish_is_one_line_exit_2_before_any_frame(memory_bus, capsys):
    status, out, err = detect(["params/hsv_demo.yaml", "--source", "demo:frames=3",
                               "--publish", "memory:/x,master=http://unreachable:1/"], capsys)
    assert (status, out) == (2, "")
    assert err == ("objrec-detect: error: --publish memory:/x,master=http://unreachable:1/: the master at "
                   "http://unreachable:1/ does not answer\n")


def test_publishers_opened_before_one_that_fails_are_closed(memory_bus, capsys):
    status, _, err = detect(["params/hsv_demo.yaml", "--source", "demo:frames=3", "--publish", "memory:/first",
                             "--publish", "memory:/second,master=http://unreachable:1/"], capsys)
    assert status == 2 and err.count("\n") == 1
    assert [t.options for t in memory_bus.transports] == [{}]  # the first target's, joined and...
    assert all(t.closed for t in memory_bus.transports)  # ...left again
    assert memory_bus.publishers == {"/first": 0}


def test_a_live_source_that_never_publishes_is_one_line_exit_2(memory_bus, capsys):
    status, out, err = detect(["params/hsv_demo.yaml", "--source", "memory:/nothing,timeout=0.3"], capsys)
    assert status == 2 and out == ""
    assert err.startswith("objrec-detect: error: memory:/nothing,timeout=0.3: no images (sensor_msgs/Image or "
                          "CompressedImage): no publisher of /nothing within 0.3 s")
    assert err.count("\n") == 1


def test_sigterm_ends_a_run_waiting_for_its_next_live_frame(memory_bus, bagmaker, demo_images, capsys, caplog):
    listener = MemoryTransport.open({}, "listener")
    listener.subscribe("/detected")

    def stop_after_first() -> None:
        if len(memory_bus.wait_sent("/detected", 1, HANG_GUARD)) >= 1:
            os.kill(os.getpid(), signal.SIGTERM)  # the run now waits for a second frame that never comes

    with Camera(memory_bus, bagmaker.Messages("ros1"), demo_images, "/detected", 1):
        stopper = threading.Thread(target=stop_after_first, daemon=True)
        stopper.start()
        status, out, err = detect(["params/hsv_demo.yaml", "--source", f"memory:{CAMERA}",
                                   "--publish", "memory:/detected"], capsys)
        stopper.join(HANG_GUARD)
    assert status == 0, err
    assert len(out.splitlines()) == 1
    assert "stopped by SIGTERM after 1 frames" in caplog.text
    assert "objrec-detect: 1 messages published on memory:/detected to 1 subscriber\n" in err


def test_list_topics_of_a_live_system(memory_bus, bagmaker, capsys):
    maker = bagmaker.Messages("ros1")
    camera = MemoryTransport.open({}, "camera")
    camera.advertise(CAMERA, "sensor_msgs/msg/Image", maker.store)
    camera.advertise("/camera/depth/points", "sensor_msgs/msg/PointCloud2", maker.store)
    status, out, err = detect(["--list-topics", "memory:,master=http://127.0.0.1:9/"], capsys)
    assert status == 0, err
    assert out.splitlines() == [
        "topic                  type",
        "/camera/depth/points   sensor_msgs/msg/PointCloud2",
        "/camera/rgb/image_raw  sensor_msgs/msg/Image",
        "memory (master=http://127.0.0.1:9/): 2 topics published",
    ]
    status, out, err = detect(["--list-topics", "memory:,master=http://unreachable:1/"], capsys)
    assert status == 2 and out == ""
    assert err == ("objrec-detect: error: memory:,master=http://unreachable:1/: the master at http://unreachable:1/ "
                   "does not answer\n")


def test_ros2_without_its_extra_is_one_line_exit_2(project_root: Path):
    blocked = "import sys; sys.modules['cyclonedds'] = None\n" + memory_transport.DETECT_CHILD
    for argv, option in ((["--source", "demo:frames=2", "--publish", "ros2:/detected"], "--publish "), ([
            "--source", "ros2:/camera/color/image_raw"], "")):
        result = subprocess.run([sys.executable, "-c", blocked, "params/hsv_demo.yaml", *argv], capture_output=True,
                                text=True, cwd=project_root, timeout=HANG_GUARD)
        assert result.returncode == 2, result.stderr
        assert result.stdout == ""
        assert result.stderr.startswith(f"objrec-detect: error: {option}ros2:/")
        assert result.stderr.rstrip("\n").endswith("ros2: needs the ros2 extra: pip install 'objrec[ros2]'")
        assert result.stderr.count("\n") == 1


@pytest.mark.parametrize("version", [1, 2])
def test_the_picture_encoder_makes_images_rosbags_reads_back(version, demo_images):
    encoder = PictureEncoder(version)
    header = Header(seq=4, stamp_ns=1_700_000_000_000_000_123, frame_id="cam")
    for picture, encoding in ((demo_images[0], "bgr8"), (demo_images[0][..., 2].copy(), "mono8")):
        raw = encoder(picture, header)
        store = encoder.typestore
        image = store.deserialize_ros1(raw, encoder.msgtype) if version == 1 else \
            store.deserialize_cdr(raw, encoder.msgtype)
        assert (image.encoding, image.height, image.width) == (encoding, 480, 640)
        assert np.array_equal(image.data.reshape(picture.shape), picture)
        assert (image.header.stamp.sec, image.header.stamp.nanosec, image.header.frame_id) == (1_700_000_000, 123,
                                                                                                "cam")
    with pytest.raises(ValueError, match=r"a picture is uint8 H x W x 3 \(BGR\) or H x W, got float32"):
        encoder(np.zeros((2, 2, 3), np.float32), header)
