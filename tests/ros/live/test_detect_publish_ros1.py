"""objrec-detect on a real ROS 1 system: a rospy camera publishes the demo scene's frames (Image,
CompressedImage, PointCloud2), objrec-detect subscribes and publishes its detections, and a rospy subscriber
built from the definition objrec announces receives them: rospy accepts the md5sum, and the objects equal those
objrec-detect writes for the same frames read from files.

The rospy node runs in Debian's system Python (a child process); objrec-detect runs in another child. The
camera publishes frame i (latched, again every quarter second) until the detection stamped like it arrives,
so every frame is detected and none is lost to the newest-wins rule whatever the speed; then SIGTERM ends
objrec-detect while it waits for a next frame.
"""

from __future__ import annotations

import base64
import importlib.util
import json
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import cv2
import pytest
from rosbags.typesys import Stores, get_typestore

from objrec2d.messages import DetectedObject2DArray
from objrec3d import write_pcd
from objrec3d.messages import DetectedObject3DArray
from objrec_core import DetectedObjectArray, Header, open_source
from objrec_ros.encode import DetectionEncoder
from tests.ros.live import memory_transport, ros1_env
from tests.ros.live.ros1_env import Ros1Master, RospyNode

ros1_master = ros1_env.ros1_master  # the fixture, used by name

#: Hang guard for a whole exchange (3D detection of a 640 x 480 cloud takes seconds on a loaded machine).
HANG_GUARD = 600.0

CAMERA_NODE = r"""
import base64, io, json, os, sys, threading
import genpy.dynamic
import rospy
from sensor_msgs.msg import CompressedImage, Image, PointCloud2

folder, topic, type_name, detections_topic, detections_type, definition_file = sys.argv[1:7]
annotated_topic = sys.argv[7] if len(sys.argv) > 7 else ""
message_class = {"Image": Image, "CompressedImage": CompressedImage, "PointCloud2": PointCloud2}[type_name]
Detections = genpy.dynamic.generate_dynamic(detections_type, open(definition_file).read())[detections_type]
received = {}
printing = threading.Lock()

def say(kind, record):  # one write per line: rospy calls each subscription's callback in its own thread
    with printing:
        sys.stdout.write(kind + " " + json.dumps(record) + "\n")
        sys.stdout.flush()

def on_detections(message):
    stamp = message.header.stamp.to_nsec()
    if stamp in received:
        return
    buffer = io.BytesIO()
    message.serialize(buffer)
    received[stamp] = True
    say("detections", {"stamp": stamp, "seq": message.header.seq, "frame_id": message.header.frame_id,
                       "raw": base64.b64encode(buffer.getvalue()).decode()})

annotated = []

def on_annotated(message):
    annotated.append(message.header.stamp.to_nsec())
    say("annotated", {"stamp": message.header.stamp.to_nsec(), "frame_id": message.header.frame_id,
                      "encoding": message.encoding, "width": message.width, "height": message.height,
                      "step": message.step, "bytes": len(message.data)})

rospy.init_node("camera_stand_in", disable_signals=True)
publisher = rospy.Publisher(topic, message_class, queue_size=1, latch=True)
rospy.Subscriber(detections_topic, Detections, on_detections)
if annotated_topic:
    rospy.Subscriber(annotated_topic, Image, on_annotated)  # as rqt_image_view would
print("md5", Detections._md5sum, flush=True)
print("ready", flush=True)
for name in sorted(os.listdir(folder)):
    message = message_class()
    message.deserialize(open(os.path.join(folder, name), "rb").read())
    while message.header.stamp.to_nsec() not in received and not rospy.is_shutdown():
        publisher.publish(message)
        rospy.sleep(0.25)
while annotated_topic and not annotated and not rospy.is_shutdown():  # the last frame again, till one is seen
    publisher.publish(message)
    rospy.sleep(0.25)
with printing:
    print("done", flush=True)
rospy.sleep(600)
"""


def _recorder() -> Any:
    path = Path(__file__).resolve().parents[3] / "scripts" / "record_demo_bag.py"
    spec = importlib.util.spec_from_file_location("objrec_tests_record_demo_bag", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_messages(folder: Path, messages: list[Any], msgtype: str) -> None:
    """Each message's ROS 1 bytes in its own file, in order (what the rospy camera publishes)."""
    store = get_typestore(Stores.ROS1_NOETIC)
    folder.mkdir()
    for index, message in enumerate(messages):
        (folder / f"{index:04d}.msg").write_bytes(bytes(store.serialize_ros1(message, msgtype)))


def compressed_png(store: Any, image_message: Any) -> Any:
    ok, data = cv2.imencode(".png", image_message.data.reshape(image_message.height, image_message.width, 3))
    assert ok
    return store.types["sensor_msgs/msg/CompressedImage"](header=image_message.header,
                                                          format="bgr8; png compressed bgr8", data=data.reshape(-1))


def detect_from_files(project_root: Path, params: str, source: Path) -> list[dict[str, Any]]:
    done = subprocess.run([sys.executable, "-m", "objrec_apps.detect", params, "--source", str(source)],
                          capture_output=True, text=True, cwd=project_root, timeout=HANG_GUARD)
    assert done.returncode == 0, done.stderr
    return [json.loads(line) for line in done.stdout.splitlines()]


def definition_file(tmp_path: Path, array_type: type[DetectedObjectArray]) -> tuple[Path, str, str]:
    """The ROS 1 definition objrec announces for ``array_type`` (as rosbags generates it), written for genpy;
    with its ROS 1 type name and md5sum."""
    encoder = DetectionEncoder(array_type, 1)
    definition, md5sum = encoder.typestore.generate_msgdef(encoder.ros_type, ros_version=1)
    path = tmp_path / "detections.msg"
    path.write_text(definition)
    return path, encoder.ros_type.replace("/msg/", "/"), md5sum


def run_live(project_root: Path, master: Ros1Master, tmp_path: Path, *, params: str, frames: Path, topic: str,
             type_name: str, array_type: type[DetectedObjectArray], detections_topic: str, count: int,
             annotated_topic: str = "") -> tuple[list[dict[str, Any]], list[str], str, list[dict[str, Any]]]:
    """The exchange: the rospy camera, objrec-detect between, the rospy subscribers. Returns what the detections'
    subscriber received (one record per frame stamp), objrec-detect's JSON lines, its stderr, and the annotated
    images' subscriber's records."""
    definition, ros1_type, md5sum = definition_file(tmp_path, array_type)
    args = [str(frames), topic, type_name, detections_topic, ros1_type, str(definition)]
    args += [annotated_topic] if annotated_topic else []
    publish = ["--publish-annotated", f"ros1:{annotated_topic}"] if annotated_topic else []
    with RospyNode.start(CAMERA_NODE, master, tmp_path, args=args, name="camera") as camera:
        assert camera.wait_for("md5") == f"md5 {md5sum}", camera.diagnostics()  # genpy's md5sum: objrec's
        assert camera.wait_for("ready") is not None, camera.diagnostics()
        out, err = tmp_path / "detect.out", tmp_path / "detect.err"
        with out.open("w") as stdout, err.open("w") as stderr:
            detect = subprocess.Popen(
                [sys.executable, "-c", memory_transport.DETECT_CHILD, params, "--source", f"ros1:{topic},timeout=60",
                 "--publish", f"ros1:{detections_topic}", *publish], cwd=project_root, stdout=stdout, stderr=stderr)
            try:
                records = _records_until_done(camera)
                received = records.get("detections", [])
                assert len(received) == count, (records, camera.diagnostics(), err.read_text())
                detect.send_signal(signal.SIGTERM)  # it now waits for a frame that never comes
                status = detect.wait(HANG_GUARD)
            finally:
                if detect.poll() is None:
                    detect.kill()
                    detect.wait(HANG_GUARD)
        assert status == 0, err.read_text()
    return received, out.read_text().splitlines(), err.read_text(), records.get("annotated", [])


def _records_until_done(camera: RospyNode) -> dict[str, list[dict[str, Any]]]:
    """The camera node's JSON records by kind ("detections", "annotated") up to its "done" line."""
    records: dict[str, list[dict[str, Any]]] = {}
    deadline = time.monotonic() + HANG_GUARD
    while time.monotonic() < deadline:
        line = camera.line(timeout=max(0.0, deadline - time.monotonic()))
        if line is None or line == "done":
            assert line == "done", camera.diagnostics()
            return records
        kind, _, text = line.partition(" ")
        records.setdefault(kind, []).append(json.loads(text))
    pytest.fail(f"no done line within the hang guard: {camera.diagnostics()}")


def check_equal_to_files(received: list[dict[str, Any]], live_lines: list[str], file_lines: list[dict[str, Any]],
                         array_type: type[DetectedObjectArray], frame_id: str, first_stamp: int, step: int) -> None:
    """The bytes the rospy subscriber got are the typed message of the objects objrec found in the same frames
    read from files, under the live frame's header; objrec's own JSON lines of the live run say the same."""
    encoder = DetectionEncoder(array_type, 1)
    for index, record in enumerate(received):
        assert record["stamp"] == first_stamp + index * step
        assert record["frame_id"] == frame_id
        header = Header(seq=record["seq"], stamp_ns=record["stamp"], frame_id=frame_id)
        expected = array_type.from_dict({**file_lines[index], "header": header.to_dict()})
        assert base64.b64decode(record["raw"]) == encoder(expected)
    by_stamp: dict[int, list[Any]] = {}
    for line in live_lines:
        array = json.loads(line)
        stamp = array["header"]["stamp"]["secs"] * 10**9 + array["header"]["stamp"]["nsecs"]
        assert by_stamp.setdefault(stamp, array["objects"]) == array["objects"]  # a frame sent twice: same objects
    assert [by_stamp[r["stamp"]] for r in received] == [line["objects"] for line in file_lines]


@pytest.mark.slow
@pytest.mark.parametrize("compressed", [False, True], ids=["Image", "CompressedImage"])
def test_images_from_rospy_give_detections_a_rospy_subscriber_accepts(ros1_master, tmp_path, project_root,
                                                                      demo_images, compressed):
    recorder, store = _recorder(), get_typestore(Stores.ROS1_NOETIC)
    messages = [recorder.image_message(store, True, index, image) for index, image in enumerate(demo_images)]
    pictures = tmp_path / "pictures"
    pictures.mkdir()
    for index, image in enumerate(demo_images):
        cv2.imwrite(str(pictures / f"{index:04d}.png"), image)
    if compressed:
        messages = [compressed_png(store, m) for m in messages]
    write_messages(tmp_path / "frames", messages, "sensor_msgs/msg/CompressedImage" if compressed else
                   "sensor_msgs/msg/Image")
    topic = "/camera/color/image_raw" + ("/compressed" if compressed else "")
    received, lines, err, annotated = run_live(
        project_root, ros1_master, tmp_path, params="params/hsv_demo.yaml", frames=tmp_path / "frames", topic=topic,
        type_name="CompressedImage" if compressed else "Image", array_type=DetectedObject2DArray,
        detections_topic="/detected_objects_2d", count=len(demo_images), annotated_topic="/objrec/annotated")
    file_lines = detect_from_files(project_root, "params/hsv_demo.yaml", pictures)
    assert all(line["objects"] for line in file_lines)  # the demo's shapes: something to compare
    check_equal_to_files(received, lines, file_lines, DetectedObject2DArray, "camera_color_optical_frame",
                         recorder.START_NS, recorder.PERIOD_NS)
    assert "published on ros1:/detected_objects_2d to 1 subscriber" in err
    assert f"objrec-detect: ros1:{topic},timeout=60: " in err and " dropped (newest wins)" in err
    assert "stopped by SIGTERM" in err
    stamps = {recorder.START_NS + i * recorder.PERIOD_NS for i in range(len(demo_images))}
    assert annotated and all(a["stamp"] in stamps for a in annotated)  # stamped like the frames they show
    assert {(a["frame_id"], a["encoding"], a["width"], a["height"], a["step"], a["bytes"]) for a in annotated} == {
        ("camera_color_optical_frame", "bgr8", 640, 480, 640 * 3, 640 * 480 * 3)}
    assert "annotated images published on ros1:/objrec/annotated to 1 subscriber" in err


@pytest.mark.slow
def test_point_clouds_from_rospy_give_detections_a_rospy_subscriber_accepts(ros1_master, tmp_path, project_root,
                                                                            demo_clouds):
    recorder, store = _recorder(), get_typestore(Stores.ROS1_NOETIC)
    messages = [recorder.cloud_message(store, True, index, cloud) for index, cloud in enumerate(demo_clouds)]
    write_messages(tmp_path / "frames", messages, "sensor_msgs/msg/PointCloud2")
    clouds = tmp_path / "pcd"
    clouds.mkdir()
    with open_source("demo:frames=2", "3d") as source:
        for frame in source:
            write_pcd(clouds / f"{frame.index}.pcd", frame.data, "binary")
    received, lines, err, _ = run_live(project_root, ros1_master, tmp_path, params="params/shape_demo.yaml",
                                    frames=tmp_path / "frames", topic="/camera/depth/points", type_name="PointCloud2",
                                    array_type=DetectedObject3DArray, detections_topic="/detected_objects_3d",
                                    count=len(demo_clouds))
    file_lines = detect_from_files(project_root, "params/shape_demo.yaml", clouds)
    assert [len(line["objects"]) for line in file_lines] == [2, 2]  # the demo's cylinder and sphere
    check_equal_to_files(received, lines, file_lines, DetectedObject3DArray, "camera_depth_optical_frame",
                         recorder.START_NS, recorder.PERIOD_NS)
    assert "published on ros1:/detected_objects_3d to 1 subscriber" in err
