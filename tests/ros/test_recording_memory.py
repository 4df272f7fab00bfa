"""Memory proportionate for a big message inside the limits. A 10000 x 10000 bgr8 Image (300 MB, at the
pixel limit) in an uncompressed ROS 1 bag is read from the file into one buffer of its own size and decoded as a
view of it: reading it costs the message once, not the chunk, a copy and a decoded copy (923 MB before). A
20-million-point cloud (x, y, z, rgb: 320 MB, at the point limit) is decoded in its own buffer (789 MB before).
Measured as the reading child's own peak memory (tests/peak_memory.py), never wall-clock time.
"""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag1 import Writer as Writer1
from rosbags.typesys import Stores, get_typestore

PEAK_MEMORY = Path(__file__).resolve().parents[1] / "peak_memory.py"
SIDE = 10_000
MESSAGE_MB = SIDE * SIDE * 3 / 1e6
#: What one run of the reader costs beyond the message: Python, NumPy, rosbags, objrec (about 70 MB).
OVERHEAD_MB = 150
POINTS = 20_000_000
#: The memory promised for reading an input inside the limits.
MEMORY_LIMIT_MB = 500
READ = """
import sys
from objrec_core import open_source
with open_source(sys.argv[1], "2d") as source:
    frames = [(f.data.shape, int(f.data[123, 456, 0]), f.data.flags.writeable) for f in source]
assert frames == [((10000, 10000, 3), 200, True)], frames
"""


def big_image_bag(path: Path) -> Path:
    """One 10000 x 10000 bgr8 image, serialized by hand around one buffer (so the test itself stays small)."""
    store = get_typestore(Stores.ROS1_NOETIC)
    frame_id = b"camera"
    head = struct.pack("<III", 0, 1_700_000_000, 0) + struct.pack("<I", len(frame_id)) + frame_id
    head += struct.pack("<II", SIDE, SIDE) + struct.pack("<I", 4) + b"bgr8" + struct.pack("<BI", 0, SIDE * 3)
    head += struct.pack("<I", SIDE * SIDE * 3)
    raw = bytearray(len(head) + SIDE * SIDE * 3)
    raw[:len(head)] = head
    raw[len(head) + 123 * SIDE * 3 + 456 * 3] = 200  # pixel (123, 456) blue
    with Writer1(path) as writer:
        connection = writer.add_connection("/camera/image", "sensor_msgs/msg/Image", typestore=store)
        writer.write(connection, 1_700_000_000 * 10**9, raw)
    return path


def test_a_pixel_limit_image_is_read_for_the_cost_of_the_message_once(tmp_path) -> None:
    bag = big_image_bag(tmp_path / "big.bag")
    report = tmp_path / "peak"
    result = subprocess.run([sys.executable, str(PEAK_MEMORY), str(report), sys.executable, "-c", READ, str(bag)],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    peak_mb = float(report.read_text().split()[0]) / 1024
    assert peak_mb < MESSAGE_MB + OVERHEAD_MB, f"reading a {MESSAGE_MB:.0f} MB image took {peak_mb:.0f} MB"


READ_CLOUD = """
import sys
import numpy as np
from objrec_core import open_source
with open_source(sys.argv[1], "3d") as source:
    clouds = [(f.data.points.shape, f.data.points.dtype.str, f.data.points[7].tolist(), f.data.colors[7].tolist())
              for f in source]
assert clouds == [((20000000, 3), "<f4", [1.0, 2.0, 3.0], [10, 20, 30])], clouds
"""


def big_cloud_bag(path: Path) -> Path:
    """One unorganized cloud of 20 M points (x, y, z, rgb float32), serialized by hand around one buffer."""
    store = get_typestore(Stores.ROS1_NOETIC)
    frame_id = b"cloud"
    head = struct.pack("<III", 0, 1_700_000_000, 0) + struct.pack("<I", len(frame_id)) + frame_id
    head += struct.pack("<II", 1, POINTS) + struct.pack("<I", 4)
    for offset, name in enumerate((b"x", b"y", b"z", b"rgb")):
        head += struct.pack("<I", len(name)) + name + struct.pack("<IBI", 4 * offset, 7, 1)
    head += struct.pack("<BII", 0, 16, 16 * POINTS) + struct.pack("<I", 16 * POINTS)
    raw = bytearray(len(head) + 16 * POINTS + 1)
    raw[:len(head)] = head
    raw[-1] = 1  # is_dense
    point = np.frombuffer(raw, dtype=np.uint8, count=16, offset=len(head) + 7 * 16)
    point[:] = np.frombuffer(np.array([1.0, 2.0, 3.0], dtype="<f4").tobytes() + bytes([30, 20, 10, 0]),
                             dtype=np.uint8)
    del point
    with Writer1(path) as writer:
        connection = writer.add_connection("/points", "sensor_msgs/msg/PointCloud2", typestore=store)
        writer.write(connection, 1_700_000_000 * 10**9, raw)
    return path


def test_a_point_limit_cloud_is_read_within_the_memory_bound(tmp_path) -> None:
    bag = big_cloud_bag(tmp_path / "cloud.bag")
    report = tmp_path / "peak"
    result = subprocess.run([sys.executable, str(PEAK_MEMORY), str(report), sys.executable, "-c", READ_CLOUD,
                             str(bag)], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    peak_mb = float(report.read_text().split()[0]) / 1024
    assert peak_mb < MEMORY_LIMIT_MB, f"reading a {16 * POINTS / 1e6:.0f} MB cloud took {peak_mb:.0f} MB"
