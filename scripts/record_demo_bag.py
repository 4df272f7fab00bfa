"""Record the demo scenes as a ROS bag: what a TurtleBot's RGB-D camera would have written, with no robot.

The 2D demo goes on ``/camera/color/image_raw`` (``sensor_msgs/Image``, bgr8) and the 3D demo on
``/camera/depth/points`` (``sensor_msgs/PointCloud2``, organized 640 x 480, x y z and packed rgb with PCL's
32-byte point layout), both at 30 frames per second from a fixed start time, so two recordings made with the
same options are the same. The format follows the path: ``.bag`` is ROS 1, anything else a ROS 2 bag folder
(MCAP storage, or sqlite3 with ``--storage sqlite3``).

    python scripts/record_demo_bag.py out/demo.bag [--frames 30] [--kinds 2d 3d] [--seed 0]
    objrec-detect params/hsv_demo.yaml --source out/demo.bag --output out/detections.mcap
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from objrec_core import open_source

IMAGE_TOPIC = "/camera/color/image_raw"
CLOUD_TOPIC = "/camera/depth/points"
START_NS = 1_700_000_000 * 10**9  # a fixed start: the same options give the same file
PERIOD_NS = 10**9 // 30


def _header(store: Any, ros1: bool, index: int, frame_id: str) -> Any:
    stamp_ns = START_NS + index * PERIOD_NS
    types = store.types
    stamp = types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    if ros1:
        return types["std_msgs/msg/Header"](seq=index, stamp=stamp, frame_id=frame_id)
    return types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)


def image_message(store: Any, ros1: bool, index: int, image: np.ndarray) -> Any:
    """A BGR image as ``sensor_msgs/Image`` (bgr8)."""
    height, width = image.shape[:2]
    return store.types["sensor_msgs/msg/Image"](
        header=_header(store, ros1, index, "camera_color_optical_frame"), height=height, width=width,
        encoding="bgr8", is_bigendian=0, step=width * 3, data=np.ascontiguousarray(image).reshape(-1),
    )


def cloud_message(store: Any, ros1: bool, index: int, cloud: Any) -> Any:
    """An organized cloud as ``sensor_msgs/PointCloud2``: x y z float32 at 0/4/8, rgb packed at 16, 32-byte points."""
    n = cloud.width * cloud.height
    layout = np.zeros(n, dtype=np.dtype({"names": ["x", "y", "z", "rgb"], "formats": ["<f4", "<f4", "<f4", "<u4"],
                                         "offsets": [0, 4, 8, 16], "itemsize": 32}))
    points = cloud.points.reshape(-1, 3)
    layout["x"], layout["y"], layout["z"] = points[:, 0], points[:, 1], points[:, 2]
    if cloud.colors is not None:
        rgb = cloud.colors.reshape(-1, 3).astype(np.uint32)
        layout["rgb"] = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    field = store.types["sensor_msgs/msg/PointField"]
    fields = [field(name=name, offset=offset, datatype=7, count=1) for name, offset in (("x", 0), ("y", 4), ("z", 8))]
    fields.append(field(name="rgb", offset=16, datatype=7, count=1))  # packed as float32, as PCL writes it
    return store.types["sensor_msgs/msg/PointCloud2"](
        header=_header(store, ros1, index, "camera_depth_optical_frame"), height=cloud.height, width=cloud.width,
        fields=fields, is_bigendian=False, point_step=32, row_step=32 * cloud.width,
        data=layout.view(np.uint8).reshape(-1), is_dense=False,
    )


def record(path: Path, frames: int, kinds: list[str], seed: int, storage: str = "mcap") -> dict[str, int]:
    """Write the recording; returns the number of messages per topic."""
    ros1 = path.suffix == ".bag"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    writer = Writer1(path) if ros1 else Writer2(path, version=8, storage_plugin=plugin)
    written: dict[str, int] = {}
    with writer:
        plans = {"2d": (IMAGE_TOPIC, "sensor_msgs/msg/Image", image_message),
                 "3d": (CLOUD_TOPIC, "sensor_msgs/msg/PointCloud2", cloud_message)}
        for kind in kinds:
            topic, msgtype, make = plans[kind]
            connection = writer.add_connection(topic, msgtype, typestore=store)
            source = open_source(f"demo:seed={seed},frames={frames}", kind)
            for frame in source:
                message = make(store, ros1, frame.index, frame.data)
                writer.write(connection, START_NS + frame.index * PERIOD_NS, serialize(message, msgtype))
                written[topic] = written.get(topic, 0) + 1
            logging.info("%s: %d frames on %s", kind, written[topic], topic)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", type=Path, help="a .bag file (ROS 1) or a new folder (ROS 2 bag)")
    parser.add_argument("--frames", type=int, default=30, help="frames per demo scene (default 30)")
    parser.add_argument("--kinds", nargs="+", choices=("2d", "3d"), default=["2d", "3d"])
    parser.add_argument("--seed", type=int, default=0, help="the demo scenes' random seed")
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="ROS 2 storage plug-in")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="record_demo_bag: %(message)s", stream=sys.stderr)
    if args.frames < 1 or args.seed < 0:
        parser.error("--frames must be at least 1 and --seed at least 0")
    if args.output.exists():
        parser.error(f"{args.output} exists already; a recording is never overwritten")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    written = record(args.output, args.frames, args.kinds, args.seed, args.storage)
    print(f"{args.output}: " + ", ".join(f"{topic} {count} messages" for topic, count in written.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
