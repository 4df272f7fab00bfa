"""Fuzzing recordings in this process: Hypothesis over the fields of the messages objrec decodes (Image,
PointCloud2), over the embedded definitions of those types, and over the chunk headers and compressed bytes of
ROS 1 bags and MCAP files. Every recording is written by rosbags (then patched where a header is fuzzed) and read
through the kinds' bag sources or ``--list-topics``' reader; each read must give frames or raise the one error a
command prints as one line (``SourceError``, of which ``RecordingError`` is one), within bounded processor time.
The chunk limit is lowered to 16 MiB here, so a bound that does not hold shows as a failure, not as a machine
out of memory.
"""

from __future__ import annotations

import os
import resource
import tempfile
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")

from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from objrec_core import SourceError, open_source
from objrec_ros.bags import list_topics

from . import recording_files as rf

#: Most processor time one recording may take to refuse or read: a small file, a few frames.
READ_CPU_SECONDS = 3.0
FUZZ = settings(max_examples=60, deadline=timedelta(seconds=60), database=None,
                derandomize=os.environ.get("HYPOTHESIS_RANDOM") != "1",
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])
CHUNK_LIMIT = 16 << 20
ROS1 = get_typestore(Stores.ROS1_NOETIC)
ROS2 = get_typestore(Stores.ROS2_HUMBLE)


@pytest.fixture(autouse=True)
def _small_chunk_limit(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    monkeypatch.setenv("OBJREC_MAX_RECORDING_CHUNK_BYTES", str(CHUNK_LIMIT))
    monkeypatch.setenv("OBJREC_MAX_RECORDING_TEMP_BYTES", str(CHUNK_LIMIT))
    yield


def _fresh(tmp_path: Path) -> Path:
    """A new folder per example (Hypothesis runs every example in the one tmp_path)."""
    return Path(tempfile.mkdtemp(dir=tmp_path))


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def read_or_refuse(path: Path, kind: str, spec: str | None = None) -> int:
    """Frames read from ``path`` by the kind's bag source (all of them), or -1 for a one-line refusal."""
    start = _cpu()
    try:
        with open_source(spec or str(path), kind) as source:
            frames = sum(1 for _ in source)
    except SourceError as exc:
        assert "\n" not in str(exc) and str(path.name) in str(exc), str(exc)
        frames = -1
    assert _cpu() - start < READ_CPU_SECONDS
    event("refused" if frames < 0 else "read")
    return frames


def _header(store: Any, ros1: bool, stamp: int, frame_id: str = "camera") -> Any:
    types = store.types
    time = types["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
    if ros1:
        return types["std_msgs/msg/Header"](seq=0, stamp=time, frame_id=frame_id)
    return types["std_msgs/msg/Header"](stamp=time, frame_id=frame_id)


def _write(path: Path, ros1: bool, store: Any, topic: str, msgtype: str, messages: list[Any]) -> Path:
    """``messages`` as a ROS 1 bag or a bare MCAP file."""
    raws = [store.serialize_ros1(m, msgtype) if ros1 else store.serialize_cdr(m, msgtype) for m in messages]
    if ros1:
        with Writer1(path) as writer:
            connection = writer.add_connection(topic, msgtype, typestore=store)
            for i, raw in enumerate(raws):
                writer.write(connection, rf.START_NS + i, raw)
        return path
    folder = path.with_name(path.stem + "_tmp")
    with Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection(topic, msgtype, typestore=store)
        for i, raw in enumerate(raws):
            writer.write(connection, rf.START_NS + i, raw)
    return rf._bare_mcap(folder, path)


U32 = st.one_of(st.integers(0, 64), st.sampled_from([2**31 - 1, 2**31, 2**32 - 1, 100_000, 10_000_000]))
PIXEL_BYTES = {"bgr8": 3, "rgb8": 3, "mono8": 1, "mono16": 2, "bgra8": 4, "rgba8": 4, "8uc3": 3}
ENCODINGS = ["bgr8", "rgb8", "mono8", "mono16", "bgra8", "rgba8", "8UC3", "16UC1", "32FC1", "yuv422", "", "BGR8",
             "bayer_rggb8", "64FC1", "8UC3\x00"]


# -- message fields ------------------------------------------------------------------------------------------
@st.composite
def image_layout(draw: st.DrawFn) -> tuple[int, int, int, str, int]:
    """(height, width, step, encoding, data bytes): a consistent layout half the time, else one field off."""
    encoding = draw(st.sampled_from(ENCODINGS))
    height, width = draw(st.integers(1, 40)), draw(st.integers(1, 40))
    step = width * PIXEL_BYTES.get(encoding.lower(), 1) + draw(st.integers(0, 3))
    data = step * height
    field = draw(st.sampled_from(["none", "none", "height", "width", "step", "data"]))
    if field == "height":
        height = draw(U32)
    elif field == "width":
        width = draw(U32)
    elif field == "step":
        step = draw(U32)
    elif field == "data":
        data = draw(st.integers(0, 4096))
    return height, width, step, encoding, data


@FUZZ
@given(ros1=st.booleans(), layout=image_layout(), bigendian=st.integers(0, 255), stamp=st.integers(0, 2**40))
def test_image_fields(tmp_path: Path, ros1: bool, layout: tuple[int, int, int, str, int], bigendian: int,
                      stamp: int) -> None:
    height, width, step, encoding, data = layout
    store = ROS1 if ros1 else ROS2
    message = store.types[rf.IMAGE](header=_header(store, ros1, stamp), height=height, width=width,
                                    encoding=encoding, is_bigendian=bigendian, step=step,
                                    data=np.arange(data, dtype=np.uint32).astype(np.uint8))
    path = _write(_fresh(tmp_path) / ("i.bag" if ros1 else "i.mcap"), ros1, store, "/image", rf.IMAGE, [message])
    frames = read_or_refuse(path, "2d")
    if frames == 1:  # accepted: a picture encoding, and the header claimed no more than the data holds
        row = width * PIXEL_BYTES[encoding.lower()]
        assert height and width and step >= row and step * (height - 1) + row <= data


FIELD_NAMES = ["x", "y", "z", "rgb", "rgba", "r", "g", "b", "intensity", "", "x\x00"]


@st.composite
def point_fields(draw: st.DrawFn) -> list[tuple[str, int, int, int]]:
    return draw(st.lists(st.tuples(st.sampled_from(FIELD_NAMES), st.integers(0, 40), st.integers(0, 9),
                                   st.integers(0, 3)), max_size=6))


@st.composite
def cloud_layout(draw: st.DrawFn) -> tuple[list[tuple[str, int, int, int]], int, int, int, int, int]:
    """(fields, height, width, point_step, row_step, data bytes): x, y, z (and rgb) laid out as drivers do half
    the time, else one part off (the fields, a size or a step)."""
    kind = draw(st.sampled_from([(7, 4), (8, 8), (2, 1)]))  # float32, float64, uint8
    names = ["x", "y", "z", *draw(st.sampled_from([[], ["rgb"], ["r", "g", "b"], ["intensity"]]))]
    fields, offset = [], 0
    for name in names:
        datatype, size = (7, 4) if name in ("rgb", "intensity") else kind
        fields.append((name, offset, datatype, 1))
        offset += size + draw(st.sampled_from([0, 0, 4]))
    point_step = offset + draw(st.integers(0, 4))
    height, width = draw(st.sampled_from([1, 1, 2, 3])), draw(st.integers(1, 30))
    row_step = width * point_step + draw(st.sampled_from([0, 0, 8]))
    data = row_step * height
    part = draw(st.sampled_from(["none", "none", "fields", "height", "width", "point_step", "row_step", "data"]))
    if part == "fields":
        fields = draw(point_fields())
    elif part == "height":
        height = draw(U32)
    elif part == "width":
        width = draw(U32)
    elif part == "point_step":
        point_step = draw(U32)
    elif part == "row_step":
        row_step = draw(U32)
    elif part == "data":
        data = draw(st.integers(0, 4096))
    return fields, height, width, point_step, row_step, data


@FUZZ
@given(ros1=st.booleans(), layout=cloud_layout(), bigendian=st.sampled_from([False, False, True]))
def test_point_cloud2_fields(tmp_path: Path, ros1: bool,
                             layout: tuple[list[tuple[str, int, int, int]], int, int, int, int, int],
                             bigendian: bool) -> None:
    fields, height, width, point_step, row_step, data = layout
    store = ROS1 if ros1 else ROS2
    field_type = store.types["sensor_msgs/msg/PointField"]
    message = store.types[rf.POINT_CLOUD2](
        header=_header(store, ros1, rf.START_NS), height=height, width=width,
        fields=[field_type(name=n, offset=o, datatype=d, count=c) for n, o, d, c in fields],
        is_bigendian=bigendian, point_step=point_step, row_step=row_step,
        data=np.arange(data, dtype=np.uint32).astype(np.uint8), is_dense=False)
    folder = _fresh(tmp_path)
    path = _write(folder / ("c.bag" if ros1 else "c.mcap"), ros1, store, "/points", rf.POINT_CLOUD2, [message])
    read_or_refuse(path, "3d")


# -- definitions ---------------------------------------------------------------------------------------------
FIELD_TYPES = ["uint32", "int8", "string", "float64", "bool", "uint8[]", "uint32[3]", "string[]",
               "sensor_msgs/PointField[]", "std_msgs/Header", "time"]


@st.composite
def lying_definition(draw: st.DrawFn, text: str) -> str:
    """``text`` with one field's type replaced, a field dropped, a field renamed, or as it is."""
    lines = [line for line in text.splitlines() if line]
    index = draw(st.integers(1, len(lines) - 1))  # the header stays: the message is built on it
    kind, name = lines[index].split()
    edit = draw(st.sampled_from(["none", "type", "drop", "rename"]))
    if edit == "type":
        lines[index] = f"{draw(st.sampled_from(FIELD_TYPES))} {name}"
    elif edit == "drop":
        del lines[index]
    else:
        lines[index] = f"{kind} {name}_{draw(st.integers(0, 9))}"
    return "\n".join(lines) + "\n"


def _filled(store: Any, msgtype: str, ros1: bool) -> Any:
    """A message of ``msgtype`` as ``store`` defines it, every field a small valid value of its declared type."""
    from rosbags.interfaces import Nodetype

    values: dict[str, Any] = {}
    for name, (kind, detail) in store.fielddefs[msgtype][1]:
        if kind == Nodetype.NAME:
            values[name] = (_header(store, ros1, rf.START_NS) if detail == "std_msgs/msg/Header"
                            else _filled(store, detail, ros1))
        elif kind == Nodetype.BASE:
            base = detail[0]
            values[name] = ("2" if base == "string" else False if base == "bool"
                            else 2.0 if base.startswith("float") else 2)
        else:
            (inner, size) = detail
            count = size or 2
            if inner[0] == Nodetype.BASE and inner[1][0] == "string":
                values[name] = ["a"] * count
            elif inner[0] == Nodetype.BASE:
                values[name] = np.full(count, 2, dtype=np.uint8 if inner[1][0] == "uint8" else np.float64
                                       if inner[1][0].startswith("float") else np.int64).astype(
                    {"uint8": np.uint8, "uint32": np.uint32, "int8": np.int8}.get(inner[1][0], np.float64))
            else:
                values[name] = [_filled(store, inner[1], ros1) for _ in range(count)]
    return store.types[msgtype](**values)


@FUZZ
@given(ros1=st.booleans(), which=st.sampled_from(["image", "cloud"]), data=st.data())
def test_embedded_definitions(tmp_path: Path, ros1: bool, which: str, data: st.DataObject) -> None:
    msgtype, standard = ((rf.IMAGE, rf.IMAGE_STRING_HEIGHT.replace("string height", "uint32 height"))
                         if which == "image" else
                         (rf.POINT_CLOUD2, rf.CLOUD_STRING_FIELDS.replace("string fields",
                                                                          "sensor_msgs/PointField[] fields")))
    definition = data.draw(lying_definition(standard))
    try:
        store = rf.lying_store(ros1, msgtype, definition)
        if "sensor_msgs/PointField" in definition:
            store.register({"sensor_msgs/msg/PointField":
                            (ROS1 if ros1 else ROS2).fielddefs["sensor_msgs/msg/PointField"]})
        message = _filled(store, msgtype, ros1)
    except Exception:  # a definition rosbags itself cannot build: not a recording anyone could write
        event("not buildable")
        return
    path = _write(_fresh(tmp_path) / ("d.bag" if ros1 else "d.mcap"), ros1, store, "/data", msgtype, [message])
    read_or_refuse(path, "2d" if which == "image" else "3d", f"bag:{path},topic=/data")


# -- chunk headers ---------------------------------------------------------------------------------------------
def _compressed_bag(path: Path, codec: str) -> Path:
    _, messages = rf.image_messages(True, count=3, side=16)
    writer = Writer1(path)
    writer.set_compression(Writer1.CompressionFormat[codec.upper()])
    with writer:
        connection = writer.add_connection("/camera/image", rf.IMAGE, typestore=ROS1)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    return path


def _compressed_mcap(path: Path) -> Path:
    _, messages = rf.image_messages(False, count=3, side=16)
    folder = path.with_name(path.stem + "_tmp")
    writer = Writer2(folder, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        connection = writer.add_connection("/camera/image", rf.IMAGE, typestore=ROS2)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    return rf._bare_mcap(folder, path)


def _mcap_records(data: bytes) -> Iterator[tuple[int, int, int]]:
    """(opcode, body offset, body length) of each record of an MCAP file."""
    pos = 8
    while pos + 9 <= len(data):
        op, length = data[pos], int.from_bytes(data[pos + 1:pos + 9], "little")
        yield op, pos + 9, length
        pos += 9 + length
        if op == 0x02:
            return


SIZES = st.one_of(st.integers(0, 1 << 16), st.sampled_from([CHUNK_LIMIT, CHUNK_LIMIT + 1, 2**32, 2**63 - 1,
                                                            2**64 - 1]))


@FUZZ
@given(uncompressed=SIZES, compression=st.sampled_from(["zstd", "lz4", "", "zstx", "bz2"]),
       flips=st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)), max_size=4),
       index_too=st.booleans())
def test_mcap_chunk_headers(tmp_path: Path, uncompressed: int, compression: str, flips: list[tuple[int, int]],
                            index_too: bool) -> None:
    path = _compressed_mcap(_fresh(tmp_path) / "c.mcap")
    data = bytearray(path.read_bytes())
    records = list(_mcap_records(bytes(data)))
    for op, body, length in records:
        if op == 0x06:  # chunk: start, end, uncompressed_size, crc, compression, compressed size, data
            data[body + 16:body + 24] = uncompressed.to_bytes(8, "little")
            name_length = int.from_bytes(data[body + 28:body + 32], "little")
            if len(compression) == name_length:
                data[body + 32:body + 32 + name_length] = compression.encode()
            chunk_data = body + 32 + name_length + 8
            for offset, value in flips:
                if chunk_data + offset < body + length:
                    data[chunk_data + offset] = value
        elif op == 0x08 and index_too:  # its index: the uncompressed size last
            data[body + length - 8:body + length] = uncompressed.to_bytes(8, "little")
    path.write_bytes(bytes(data))
    try:
        list_topics(path)
    except SourceError as exc:
        assert "\n" not in str(exc)
    read_or_refuse(path, "2d")


@FUZZ
@given(codec=st.sampled_from(["bz2", "lz4"]), compression=st.sampled_from(["bz2", "lz4", "non", "zst"]),
       size=st.one_of(st.none(), st.integers(0, 1 << 16), st.sampled_from([CHUNK_LIMIT, CHUNK_LIMIT + 1,
                                                                           2**32 - 1])),
       flips=st.lists(st.tuples(st.integers(0, 4000), st.integers(0, 255)), max_size=4))
def test_ros1_chunk_headers(tmp_path: Path, codec: str, compression: str, size: int | None,
                            flips: list[tuple[int, int]]) -> None:
    path = _compressed_bag(_fresh(tmp_path) / "c.bag", codec)
    data = bytearray(path.read_bytes())
    marker = f"compression={codec}".encode()
    at = data.find(marker)
    assert at > 0
    data[at + len(marker) - 3:at + len(marker)] = compression.encode()
    if size is not None:  # the uncompressed size the chunk header declares
        field = data.find(b"size=", at)
        data[field + 5:field + 9] = size.to_bytes(4, "little")
    chunk_data = data.find(b"op=\x05", at) + 20  # somewhere past the chunk header: its compressed bytes
    for offset, value in flips:
        if chunk_data + offset < len(data):
            data[chunk_data + offset] = value
    path.write_bytes(bytes(data))
    try:
        list_topics(path)
    except SourceError as exc:
        assert "\n" not in str(exc)
    read_or_refuse(path, "2d")
