"""Debian's own ``rosbag`` (rospy's Python 3, not rosbags) reads the ``.bag`` objrec-detect writes: the same
number of messages as JSON lines, the type and md5sum objrec declares (and genpy computes from the stored
definition), and field values equal to the JSON Lines of the same frames."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import build_system
from objrec_ros.msgdefs import register_definitions, standard_typestore
from tests.ros.live.ros1_env import SYSTEM_PYTHON, skip_without_ros1

PARAMS = "params/hsv_demo.yaml"
TOPIC = "/objrec/coloured_object"
FRAMES = 5

# Prints, per connection, its topic, type and md5sum, and per message its topic, the md5sum of the class
# genpy generated from the bag's stored definition, and the message as plain JSON.
ROSBAG_DUMP = """
import json, sys
import genpy, rosbag

def plain(value):
    if isinstance(value, genpy.TVal):
        return {"secs": value.secs, "nsecs": value.nsecs}
    if isinstance(value, genpy.Message):
        return {slot: plain(getattr(value, slot)) for slot in value.__slots__}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, bytes):
        return list(value)
    return value

with rosbag.Bag(sys.argv[1]) as bag:
    for conn in bag._connections.values():
        print(json.dumps({"connection": conn.topic, "type": conn.datatype, "md5sum": conn.md5sum}), flush=True)
    for topic, msg, _t in bag.read_messages():
        print(json.dumps({"topic": topic, "type": msg._type, "md5sum": msg._md5sum, "msg": plain(msg)}),
              flush=True)
"""


def _detect(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    done = subprocess.run([sys.executable, "-m", "objrec_apps.detect", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    return done


def _float32(line: dict[str, Any]) -> dict[str, Any]:
    """A JSON line as rosbag reads its message back: float32 points, and the flag JSON leaves out when false."""
    for obj in line["objects"]:
        obj.setdefault("truncated", False)
        for point in obj.get("polygon", {}).get("points", []):
            for key, value in point.items():
                point[key] = float(np.float32(value))
    return line


def test_rosbag_reads_detect_output_equal_to_its_json_lines(project_root: Path, tmp_path: Path) -> None:
    skip_without_ros1()
    recording = tmp_path / "demo.bag"
    made = subprocess.run([sys.executable, "scripts/record_demo_bag.py", str(recording), "--frames", str(FRAMES),
                           "--kinds", "2d"], capture_output=True, text=True, cwd=project_root, timeout=300,
                          check=False)
    assert made.returncode == 0, made.stderr
    # the same frames (with the recording's stamps) once as JSON lines, once as a ROS 1 bag
    json_lines = [json.loads(line) for line in _detect([PARAMS, "-s", str(recording)], project_root).stdout
                  .splitlines()]
    output = tmp_path / "found.bag"
    _detect([PARAMS, "-s", str(recording), "-o", str(output)], project_root)
    assert len(json_lines) == FRAMES

    dumped = subprocess.run([SYSTEM_PYTHON, "-c", ROSBAG_DUMP, str(output)], capture_output=True, text=True,
                            timeout=300, check=False, env={"PATH": "/usr/bin:/bin"})
    assert dumped.returncode == 0, dumped.stderr
    records = [json.loads(line) for line in dumped.stdout.splitlines()]
    connections = [r for r in records if "connection" in r]
    messages = [r for r in records if "topic" in r]

    array_type = build_system(project_root / PARAMS).object_array_type
    typestore = standard_typestore(1)
    register_definitions(typestore, array_type.ros_type, array_type.ros_definitions)
    _definition, md5sum = typestore.generate_msgdef(array_type.ros_type, ros_version=1)
    ros1_type = array_type.ros_type.replace("/msg/", "/")

    assert connections == [{"connection": TOPIC, "type": ros1_type, "md5sum": md5sum}]
    assert len(messages) == len(json_lines)
    for message, line in zip(messages, json_lines, strict=True):
        assert (message["topic"], message["type"], message["md5sum"]) == (TOPIC, ros1_type, md5sum)
        assert message["msg"] == _float32(line)
    assert sum(len(m["msg"]["objects"]) for m in messages) > 0
