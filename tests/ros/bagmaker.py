"""Test recordings written with rosbags itself: ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) and bare MCAP
files, holding the sensor messages objrec reads, in the layouts drivers use (row padding, big-endian data,
PCL's padded point layout, other field orders).

Tests run with ``--import-mode=importlib``, so this module is not importable by name: ``tests/ros/conftest.py``
loads it by path and hands it out as the ``bagmaker`` fixture (``bagmaker.Messages``, ``bagmaker.write``...).
"""

from __future__ import annotations

import shutil
import sqlite3
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

#: ros1: a .bag; sqlite3 / mcap: a ROS 2 bag folder; mcap-file: a bare .mcap file (no metadata.yaml).
FORMATS = ("ros1", "sqlite3", "mcap", "mcap-file")

IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"

#: A message type no ROS distribution has.
BLOB_TYPE = "acme_msgs/msg/Blob"
BLOB_DEFINITION = "uint32 value\nstring note\n"

_FIELD_TYPES = {"float32": (7, "<f4", ">f4"), "float64": (8, "<f8", ">f8"), "uint32": (6, "<u4", ">u4")}


@dataclass
class Entry:
    """One message to write: topic, type, log time and the typed message."""

    topic: str
    msgtype: str
    log_ns: int
    message: Any


def stamp_ns(seconds: float) -> int:
    return round(seconds * 1e9)


class Messages:
    """Builds typed messages for one ROS version (ROS 1 headers have a sequence number, ROS 2 ones do not)."""

    def __init__(self, fmt: str) -> None:
        self.fmt = fmt
        self.ros1 = fmt == "ros1"
        self.store = get_typestore(Stores.ROS1_NOETIC if self.ros1 else Stores.ROS2_HUMBLE)
        self.custom: set[str] = set()

    def serialize(self, message: Any, msgtype: str) -> memoryview:
        return self.store.serialize_ros1(message, msgtype) if self.ros1 else self.store.serialize_cdr(message, msgtype)

    def header(self, stamp: int, frame_id: str, seq: int = 0) -> Any:
        types = self.store.types
        time = types["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
        if self.ros1:
            return types["std_msgs/msg/Header"](seq=seq, stamp=time, frame_id=frame_id)
        return types["std_msgs/msg/Header"](stamp=time, frame_id=frame_id)

    def image(self, pixels: np.ndarray, encoding: str, stamp: int, frame_id: str = "camera", *, pad: int = 0,
              bigendian: bool = False) -> Any:
        """``pixels`` in the encoding's own layout (H x W or H x W x C, its dtype); ``pad`` bytes end each row."""
        pixels = np.asarray(pixels)
        height, width = pixels.shape[:2]
        if pixels.dtype.itemsize > 1:
            pixels = pixels.astype(pixels.dtype.newbyteorder(">" if bigendian else "<"))
        rows = np.ascontiguousarray(pixels).view(np.uint8).reshape(height, -1)
        row = rows.shape[1]
        if pad:
            rows = np.concatenate([rows, np.full((height, pad), 0xAB, dtype=np.uint8)], axis=1)
        return self.store.types[IMAGE](
            header=self.header(stamp, frame_id), height=height, width=width, encoding=encoding,
            is_bigendian=int(bigendian), step=row + pad, data=rows.reshape(-1).copy(),
        )

    def compressed(self, image: np.ndarray, fmt: str, stamp: int, frame_id: str = "camera") -> Any:
        """``fmt`` jpeg or png, encoded by OpenCV as image_transport's compressed plug-in does."""
        ok, data = cv2.imencode(".jpg" if fmt == "jpeg" else ".png", image)
        assert ok
        label = f"bgr8; {fmt} compressed bgr8" if image.ndim == 3 else f"mono8; {fmt} compressed mono8"
        return self.store.types[COMPRESSED_IMAGE](header=self.header(stamp, frame_id), format=label,
                                                  data=data.reshape(-1).astype(np.uint8))

    def cloud(self, points: np.ndarray, colors: np.ndarray | None, stamp: int, frame_id: str = "cloud", *,
              order: Sequence[str] = ("x", "y", "z", "rgb"), gap: int = 0, tail: int = 0, row_pad: int = 0,
              xyz: str = "float32", rgb: str = "float32", rgb_name: str = "rgb", alpha: int = 0,
              offsets: dict[str, int] | None = None, point_step: int | None = None,
              bigendian: bool = False) -> Any:
        """A PointCloud2 of ``points`` (H x W x 3 organized, N x 3 not) and RGB ``colors`` packed into one
        4-byte field; fields in ``order`` with ``gap`` bytes after each, ``tail`` bytes after the last, and
        ``row_pad`` bytes after each row; or at explicit ``offsets`` in points of ``point_step`` bytes."""
        points = np.asarray(points, dtype=np.float32)
        height, width = (points.shape[0], points.shape[1]) if points.ndim == 3 else (1, points.shape[0])
        flat = points.reshape(-1, 3)
        names, formats, places, fields = [], [], [], []
        offset = 0
        field_type = self.store.types["sensor_msgs/msg/PointField"]
        for name in order:
            if name == "rgb":
                if colors is None:
                    continue
                datatype, little, big = _FIELD_TYPES[rgb]
                numpy_type = big.replace("f", "u") if bigendian else little.replace("f", "u")  # the packed bits
                name = rgb_name
            else:
                datatype, little, big = _FIELD_TYPES[xyz]
                numpy_type = big if bigendian else little
            if offsets is not None:
                offset = offsets["rgb" if name == rgb_name else name]
            names.append(name)
            formats.append(numpy_type)
            places.append(offset)
            fields.append(field_type(name=name, offset=offset, datatype=datatype, count=1))
            offset += np.dtype(numpy_type).itemsize + gap
        if point_step is None:
            point_step = offset - gap + tail
        layout = np.zeros(len(flat), dtype=np.dtype({"names": names, "formats": formats, "offsets": places,
                                                     "itemsize": point_step}))
        for axis, name in enumerate("xyz"):
            if name in names:
                layout[name] = flat[:, axis]
        if colors is not None:
            c = np.asarray(colors).reshape(-1, 3).astype(np.uint32)
            layout[rgb_name] = (np.uint32(alpha) << 24) | (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]
        rows = layout.view(np.uint8).reshape(height, width * point_step)
        if row_pad:
            rows = np.concatenate([rows, np.full((height, row_pad), 0xCD, dtype=np.uint8)], axis=1)
        return self.store.types[POINT_CLOUD2](
            header=self.header(stamp, frame_id), height=height, width=width, fields=fields, is_bigendian=bigendian,
            point_step=point_step, row_step=width * point_step + row_pad, data=rows.reshape(-1).copy(),
            is_dense=False,
        )

    def camera_info(self, width: int, height: int, fx: float, fy: float, cx: float, cy: float, stamp: int,
                    frame_id: str = "camera") -> Any:
        k = np.array([fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0])
        r = np.eye(3).reshape(-1)
        p = np.array([fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0])
        roi = self.store.types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                                   do_rectify=False)
        fields = {"d": np.zeros(5), "k": k, "r": r, "p": p} if not self.ros1 else \
            {"D": np.zeros(5), "K": k, "R": r, "P": p}
        return self.store.types[CAMERA_INFO](
            header=self.header(stamp, frame_id), height=height, width=width, distortion_model="plumb_bob",
            binning_x=0, binning_y=0, roi=roi, **fields,
        )

    def blob(self, value: int, note: str = "") -> Any:
        """A message of a type no ROS distribution has (registered in this maker's typestore)."""
        if BLOB_TYPE not in self.store.fielddefs:
            self.store.register(get_types_from_msg(BLOB_DEFINITION, BLOB_TYPE))
        return self.store.types[BLOB_TYPE](value=value, note=note)


def recording_path(base: Path, fmt: str) -> Path:
    """Where ``write`` puts a recording of ``fmt`` named after ``base``."""
    return {"ros1": base.with_suffix(".bag"), "mcap-file": base.with_suffix(".mcap")}.get(fmt, base)


def write(base: Path, fmt: str, maker: Messages, entries: Iterable[Entry]) -> Path:
    """Write ``entries`` (in any order) as a recording of ``fmt``; returns its path (``recording_path``)."""
    entries = sorted(entries, key=lambda e: e.log_ns)
    target = recording_path(Path(base), fmt)
    folder = target if fmt in ("sqlite3", "mcap") else Path(base).with_name(Path(base).name + "_tmpbag")
    if fmt == "ros1":
        writer: Any = Writer1(target)
    else:
        plugin = StoragePlugin.SQLITE3 if fmt == "sqlite3" else StoragePlugin.MCAP
        writer = Writer2(folder, version=9, storage_plugin=plugin)
    connections: dict[str, Any] = {}
    with writer:
        for entry in entries:
            if entry.topic not in connections:
                connections[entry.topic] = writer.add_connection(entry.topic, entry.msgtype, typestore=maker.store)
            writer.write(connections[entry.topic], entry.log_ns, maker.serialize(entry.message, entry.msgtype))
    if fmt == "mcap-file":
        shutil.move(str(folder / f"{folder.name}.mcap"), target)
        shutil.rmtree(folder)
    return target


def drop_definition(folder: Path, msgtype: str) -> None:
    """Remove a type's definition from a ROS 2 sqlite3 bag, as a recorder without the type's package would
    have written it: the messages stay, nothing says how to decode them."""
    database = next(Path(folder).glob("*.db3"))
    with sqlite3.connect(database) as connection:
        connection.execute("DELETE FROM message_definitions WHERE topic_type = ?", (msgtype,))
    connection.close()


def truncate(path: Path, fraction: float = 0.5) -> None:
    """Cut a recording's storage file to ``fraction`` of its bytes, as a recorder killed mid-write leaves it."""
    path = Path(path)
    file = path if path.is_file() else next(p for p in path.iterdir() if p.suffix in (".db3", ".mcap"))
    data = file.read_bytes()
    file.write_bytes(data[: int(len(data) * fraction)])
