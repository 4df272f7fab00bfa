"""Small code that makes hostile recordings: compression bombs in every place a recording
compresses (a ROS 1 bz2 or lz4 chunk, an MCAP zstd or lz4 chunk, a ROS 2 per-message zstd payload, a
file-compressed ROS 2 bag), embedded definitions that lie about a field's type, and ``metadata.yaml`` fields of
the wrong kind.

Each recording is written by rosbags' own writers, with the one part that should be compressed replaced by a
bomb: the real bytes compressed, then a run of zeros compressed in streams or frames of 40 MiB (a few bytes
each), so the whole file stays kilobytes and inflates to ``gigabytes``.
"""

from __future__ import annotations

import bz2
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any

import lz4.frame
import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

try:
    from compression import zstd  # type: ignore[import-not-found]
except ImportError:
    from backports import zstd  # type: ignore[import-not-found,no-redef]

IMAGE = "sensor_msgs/msg/Image"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
#: One zero run, compressed once and repeated.
_RUN = 40 << 20
GIB = 1 << 30
START_NS = 1_700_000_000 * 10**9


def streamed_zstd(data: bytes) -> bytes:
    """A zstd frame written as a stream: its header does not declare the size it inflates to."""
    compressor = zstd.ZstdCompressor()
    return compressor.compress(data) + compressor.flush()


#: How each codec compresses; ``zstd-stream`` is zstd whose frames do not declare their size.
COMPRESS = {"bz2": lambda d: bz2.compress(d, 9), "lz4": lz4.frame.compress, "zstd": zstd.compress,
            "zstd-stream": streamed_zstd}


@cache
def zero_run(codec: str) -> bytes:
    """40 MiB of zeros as one bz2 stream, lz4 frame or zstd frame."""
    return COMPRESS[codec](bytes(_RUN))


def bomb(codec: str, real: bytes, inflated: int) -> bytes:
    """``real`` compressed with ``codec``, then zeros up to about ``inflated`` bytes in all."""
    return COMPRESS[codec](real) + zero_run(codec) * max(1, inflated // _RUN)


def image_messages(fmt_ros1: bool, count: int = 2, side: int = 32) -> tuple[Any, list[tuple[int, bytes]]]:
    """A standard typestore and ``count`` small bgr8 images serialized for it, with their log times."""
    store = get_typestore(Stores.ROS1_NOETIC if fmt_ros1 else Stores.ROS2_HUMBLE)
    types = store.types
    out = []
    for i in range(count):
        stamp = START_NS + i * 100_000_000
        time = types["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
        header = (types["std_msgs/msg/Header"](seq=i, stamp=time, frame_id="camera") if fmt_ros1
                  else types["std_msgs/msg/Header"](stamp=time, frame_id="camera"))
        pixels = np.full((side, side, 3), 40 * i, dtype=np.uint8)
        message = types[IMAGE](header=header, height=side, width=side, encoding="bgr8", is_bigendian=0,
                               step=side * 3, data=pixels.reshape(-1))
        raw = store.serialize_ros1(message, IMAGE) if fmt_ros1 else store.serialize_cdr(message, IMAGE)
        out.append((stamp, bytes(raw)))
    return store, out


def ros1_chunk_bomb(path: Path, codec: str = "bz2", inflated: int = GIB, declare: int | None = None) -> Path:
    """A ROS 1 bag of two images whose one chunk (bz2 or lz4) inflates to ``inflated`` bytes; ``declare``
    (bytes, below 4 GiB) makes the chunk header's ``size`` claim that instead of the true small one."""
    store, messages = image_messages(True)
    writer = Writer1(path)
    writer.set_compression(Writer1.CompressionFormat[codec.upper()])
    writer.compressor = lambda data: bomb(codec, data, inflated)  # type: ignore[method-assign]
    with writer:
        connection = writer.add_connection("/camera/image", IMAGE, typestore=store)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    if declare is not None:
        data = bytearray(path.read_bytes())
        at = data.find(f"compression={codec}".encode())
        size = data.find(b"size=", at)
        assert at > 0 and 0 < size - at < 64
        data[size + 5:size + 9] = declare.to_bytes(4, "little")
        path.write_bytes(bytes(data))
    return path


def _bare_mcap(folder: Path, target: Path) -> Path:
    shutil.move(str(folder / f"{folder.name}.mcap"), target)
    shutil.rmtree(folder)
    return target


def mcap_chunk_bomb(path: Path, codec: str = "zstd", inflated: int = GIB, declare: int | None = None) -> Path:
    """A bare MCAP file of two images whose chunk inflates to ``inflated`` bytes; ``declare`` (bytes) makes the
    chunk header claim that uncompressed size instead of the true small one. ``codec`` ``zstd-stream``: zstd
    frames that do not declare their sizes either."""
    store, messages = image_messages(False)
    folder = path.with_name(path.stem + "_tmp")
    writer = Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        storage: Any = writer.storage
        storage.compression = codec.split("-")[0]
        storage.compressor = lambda data: bomb(codec, data, inflated)
        connection = writer.add_connection("/camera/image", IMAGE, typestore=store)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    target = _bare_mcap(folder, path)
    if declare is not None:
        _declare_chunk_size(target, declare)
    return target


def _declare_chunk_size(path: Path, size: int) -> None:
    """Rewrite the uncompressed_size of every chunk record (op 0x06) and its index (op 0x08) of an MCAP file."""
    data = bytearray(path.read_bytes())
    pos = 8
    while pos < len(data) - 8:
        op = data[pos]
        length = int.from_bytes(data[pos + 1:pos + 9], "little")
        body = pos + 9
        if op == 0x06:  # chunk: start, end, uncompressed_size, crc...
            data[body + 16:body + 24] = size.to_bytes(8, "little")
            data[body + 24:body + 28] = bytes(4)  # no crc
        elif op == 0x08:  # chunk index: start, end, chunk_start, chunk_length, map..., compressed, uncompressed
            data[body + length - 8:body + length] = size.to_bytes(8, "little")
        pos = body + length
        if op == 0x02:  # footer
            break
    path.write_bytes(bytes(data))


@contextmanager
def _message_compressor(compress: Callable[[bytes], bytes]) -> Iterator[None]:
    from rosbags.rosbag2 import writer as writer2

    saved = writer2.zstd
    writer2.zstd = type("Z", (), {"compress": staticmethod(compress)})  # type: ignore[assignment]
    try:
        yield
    finally:
        writer2.zstd = saved  # type: ignore[assignment]


def message_bomb(folder: Path, inflated: int = GIB, codec: str = "zstd") -> Path:
    """A ROS 2 bag folder (MCAP storage, per-message zstd) whose messages each inflate to ``inflated`` bytes
    (``codec`` ``zstd-stream``: frames that do not declare their sizes)."""
    store, messages = image_messages(False)
    writer = Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    with _message_compressor(lambda data: bomb(codec, bytes(data), inflated)), writer:
        connection = writer.add_connection("/camera/image", IMAGE, typestore=store)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    return folder


def file_bomb(folder: Path, inflated: int = 30 * GIB) -> Path:
    """A ROS 2 bag folder (MCAP storage, file compression) whose storage file inflates to ``inflated`` bytes:
    the real file, then zeros, as zstd frames that do not declare the size they add up to."""
    store, messages = image_messages(False)
    writer = Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
    with writer:
        connection = writer.add_connection("/camera/image", IMAGE, typestore=store)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    compressed = next(folder.glob("*.zstd"))
    real = zstd.decompress(compressed.read_bytes())
    compressed.write_bytes(zstd.compress(real) + zero_run("zstd") * max(1, inflated // _RUN))
    return folder


# -- lying definitions ------------------------------------------------------------------------------------
IMAGE_STRING_HEIGHT = """std_msgs/Header header
string height
uint32 width
string encoding
uint8 is_bigendian
uint32 step
uint8[] data
"""
CLOUD_STRING_FIELDS = """std_msgs/Header header
uint32 height
uint32 width
string fields
bool is_bigendian
uint32 point_step
uint32 row_step
uint8[] data
bool is_dense
"""


def lying_store(ros1: bool, msgtype: str, definition: str) -> Any:
    """A typestore whose ``msgtype`` is ``definition`` (the standard types it builds on as usual)."""
    standard = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    store = get_typestore(Stores.EMPTY)
    keep = {n: d for n, d in standard.fielddefs.items() if not n.startswith("sensor_msgs/")}
    store.register(keep)
    store.register(get_types_from_msg(definition, msgtype))
    return store


def lying_recording(path: Path, fmt: str, msgtype: str, definition: str, values: dict[str, Any]) -> Path:
    """A recording (``ros1``: a .bag; ``mcap-file``: a bare .mcap) of one message of ``msgtype`` as
    ``definition`` has it, embedded; ``values`` are its fields besides the header."""
    ros1 = fmt == "ros1"
    store = lying_store(ros1, msgtype, definition)
    types = store.types
    time = types["builtin_interfaces/msg/Time"](sec=START_NS // 10**9, nanosec=0)
    header = (types["std_msgs/msg/Header"](seq=0, stamp=time, frame_id="camera") if ros1
              else types["std_msgs/msg/Header"](stamp=time, frame_id="camera"))
    message = types[msgtype](header=header, **values)
    raw = store.serialize_ros1(message, msgtype) if ros1 else store.serialize_cdr(message, msgtype)
    topic = "/camera/image" if msgtype == IMAGE else "/points"
    if ros1:
        with Writer1(path) as writer:
            connection = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connection, START_NS, raw)
        return path
    folder = path.with_name(path.stem + "_tmp")
    with Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection(topic, msgtype, typestore=store)
        writer.write(connection, START_NS, raw)
    return _bare_mcap(folder, path)


def image_with_string_height(path: Path, fmt: str = "ros1") -> Path:
    return lying_recording(path, fmt, IMAGE, IMAGE_STRING_HEIGHT, {
        "height": "lots", "width": 4, "encoding": "bgr8", "is_bigendian": 0, "step": 12,
        "data": np.zeros(48, dtype=np.uint8)})


def cloud_with_string_fields(path: Path, fmt: str = "ros1") -> Path:
    return lying_recording(path, fmt, POINT_CLOUD2, CLOUD_STRING_FIELDS, {
        "height": 1, "width": 2, "fields": "x y z", "is_bigendian": False, "point_step": 12, "row_step": 24,
        "data": np.zeros(24, dtype=np.uint8), "is_dense": True})


def plain_bag_folder(folder: Path) -> Path:
    """A valid ROS 2 bag folder (MCAP storage) of two images: its metadata.yaml is what the cases edit."""
    store, messages = image_messages(False)
    with Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/camera/image", IMAGE, typestore=store)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    return folder


def edit_metadata(folder: Path, old: str, new: str) -> Path:
    """Replace text in a bag folder's metadata.yaml (``message_count: 2`` -> ``message_count: lots``)."""
    metadata = folder / "metadata.yaml"
    text = metadata.read_text(encoding="utf-8")
    assert old in text, (old, text)
    metadata.write_text(text.replace(old, new, 1), encoding="utf-8")
    return folder
