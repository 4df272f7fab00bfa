"""objrec-detect on ROS 2 over DDS (loopback only): a plain cyclonedds camera, written as ROS 2's generated code
spells the types, publishes the demo scene's images; objrec-detect subscribes (``ros2:``) and publishes its
detections (``--publish ros2:``); a plain cyclonedds reader of ``object_detection_2d_msgs::msg::dds_::
DetectedObject2DArray_`` on ``rt/detected_objects_2d`` receives them, and the objects equal those objrec-detect
writes for the same frames read from files.

The camera and the reader are one child process; it publishes frame i (again every quarter second) until the
detection stamped like it arrives, so every frame is detected whatever the speed; then SIGTERM ends objrec-detect.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
from typing import Any

import cv2
import numpy as np
import pytest

from tests.ros.live import memory_transport

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")


from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out

dds_env = dds.dds_env  # the fixture, used by name

HANG_GUARD = 300.0
START_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10**9 // 30

#: A ROS 2 camera and a ROS 2 consumer of the detections, in plain cyclonedds with hand-written types.
CAMERA_AND_CONSUMER = dds.ROS2_IMAGE_IDL + r'''
import json, os, sys, time
import numpy as np
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

@dataclass
class Point32(IdlStruct, typename="geometry_msgs::msg::dds_::Point32_"):
    x: types.float32
    y: types.float32
    z: types.float32

@dataclass
class Polygon(IdlStruct, typename="geometry_msgs::msg::dds_::Polygon_"):
    points: types.sequence[Point32]

@dataclass
class DetectedObject2D(IdlStruct, typename="object_detection_2d_msgs::msg::dds_::DetectedObject2D_"):
    name: str
    polygon: Polygon
    truncated: bool

@dataclass
class DetectedObject2DArray(IdlStruct, typename="object_detection_2d_msgs::msg::dds_::DetectedObject2DArray_"):
    header: Header
    objects: types.sequence[DetectedObject2D]

folder, start, period = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
participant = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
camera = DataWriter(participant, Topic(participant, "rt/camera/color/image_raw", Image),
                    qos=Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(5)))  # rclcpp's SensorDataQoS
reader = DataReader(participant, Topic(participant, "rt/detected_objects_2d", DetectedObject2DArray),
                    qos=Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10)))
print("ready", flush=True)
received = set()
for index, name in enumerate(sorted(os.listdir(folder))):
    pixels = np.load(os.path.join(folder, name))
    stamp = start + index * period
    image = Image(Header(Time(stamp // 10**9, stamp % 10**9), "camera_color_optical_frame"), pixels.shape[0],
                  pixels.shape[1], "bgr8", 0, pixels.shape[1] * 3, pixels.tobytes())
    deadline = time.monotonic() + 240
    while stamp not in received and time.monotonic() < deadline:
        camera.write(image)
        time.sleep(0.25)
        for sample in reader.take(N=20):
            got = sample.header.stamp.sec * 10**9 + sample.header.stamp.nanosec
            if got in received:
                continue
            received.add(got)
            objects = [{"name": o.name, "polygon": {"points": [{"x": p.x, "y": p.y, "z": p.z}
                                                               for p in o.polygon.points]}} for o in sample.objects]
            print("detections", json.dumps({"stamp": got, "frame_id": sample.header.frame_id, "objects": objects}),
                  flush=True)
print("done", flush=True)
time.sleep(600)
'''


def _lines_until(child: subprocess.Popen, wanted: str) -> list[str]:
    """The child's stdout lines up to and including the first that starts with ``wanted`` (a hang guard ends
    the wait: the child is killed by the caller)."""
    lines = []
    assert child.stdout is not None
    for line in child.stdout:
        lines.append(line.strip())
        if line.startswith(wanted):
            return lines
    pytest.fail(f"the child ended before {wanted!r}: {lines}")


def _float32(objects: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """JSON objects with their points as float32 values, as a ROS Point32 holds them."""
    return [{"name": o["name"], "polygon": {"points": [{k: float(np.float32(v)) for k, v in p.items()}
                                                      for p in o["polygon"]["points"]]}} for o in objects]


@pytest.mark.slow
def test_a_ros2_camera_gives_detections_a_plain_dds_consumer_reads(dds_env, tmp_path, project_root, demo_images):
    frames, pictures = tmp_path / "frames", tmp_path / "pictures"
    frames.mkdir()
    pictures.mkdir()
    for index, image in enumerate(demo_images):
        np.save(frames / f"{index:04d}.npy", image)
        cv2.imwrite(str(pictures / f"{index:04d}.png"), image)
    camera = subprocess.Popen([sys.executable, "-c", CAMERA_AND_CONSUMER, str(frames), str(START_NS), str(PERIOD_NS)],
                              env=dds_env.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    detect = None
    try:
        _lines_until(camera, "ready")
        out, err = tmp_path / "detect.out", tmp_path / "detect.err"
        with out.open("w") as stdout, err.open("w") as stderr:
            detect = subprocess.Popen(
                [sys.executable, "-c", memory_transport.DETECT_CHILD, "params/hsv_demo.yaml",
                 "--source", f"ros2:/camera/color/image_raw,domain={dds_env.domain},timeout=60",
                 "--publish", f"ros2:/detected_objects_2d,domain={dds_env.domain}"],
                cwd=project_root, env=dds_env.env, stdout=stdout, stderr=stderr)
            timer = _killer([camera, detect])
            lines = _lines_until(camera, "done")
            detect.send_signal(signal.SIGTERM)  # it now waits for a frame that never comes
            status = detect.wait(HANG_GUARD)
            timer.cancel()
    finally:
        for child in (camera, detect):
            if child is not None and child.poll() is None:
                child.kill()
                child.wait(HANG_GUARD)
    assert status == 0, err.read_text()
    received = [json.loads(line.split(" ", 1)[1]) for line in lines if line.startswith("detections ")]
    assert [r["stamp"] for r in received] == [START_NS + i * PERIOD_NS for i in range(len(demo_images))]
    assert {r["frame_id"] for r in received} == {"camera_color_optical_frame"}
    done = subprocess.run([sys.executable, "-m", "objrec_apps.detect", "params/hsv_demo.yaml", "--source",
                           str(pictures)], capture_output=True, text=True, cwd=project_root, timeout=HANG_GUARD)
    assert done.returncode == 0, done.stderr
    from_files = [json.loads(line)["objects"] for line in done.stdout.splitlines()]
    assert all(from_files)  # the demo's shapes: something to compare
    assert [r["objects"] for r in received] == [_float32(objects) for objects in from_files]
    live = {}
    for line in out.read_text().splitlines():
        array = json.loads(line)
        live[array["header"]["stamp"]["secs"] * 10**9 + array["header"]["stamp"]["nsecs"]] = array["objects"]
    assert [live[r["stamp"]] for r in received] == from_files
    assert f"published on ros2:/detected_objects_2d,domain={dds_env.domain} to 1 subscriber" in err.read_text()


def _killer(children: list[subprocess.Popen]) -> Any:
    """A hang guard: kills the children if the exchange has not ended after HANG_GUARD seconds."""
    timer = threading.Timer(HANG_GUARD, lambda: [c.kill() for c in children if c.poll() is None])
    timer.daemon = True
    timer.start()
    return timer
