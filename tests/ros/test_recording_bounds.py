"""Recordings: every decompression bounded, lying definitions and metadata one line, detections on
their inputs' timeline, compressed MCAP output. In-process, with the limits lowered through their environment
variables so that each bomb is small; the real-size bombs run as commands in tests/hostile/test_hostile_recordings.py.
"""

from __future__ import annotations

import bz2
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import lz4.frame
import numpy as np
import pytest

pytest.importorskip("rosbags")

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from objrec_core import DetectedObjectArray, Header
from objrec_ros.bag_metadata import MetadataError, check_metadata
from objrec_ros.bags import RecordingError, open_recording
from objrec_ros.bounded import DeclaredSizeError, InflateError, check_temp_space, inflate, zstd_declared
from objrec_ros.output import InputCopy, open_detection_writer
from objrec_ros.source import Origin, Origins
from strictio.limits import RECORDING_CHUNK_BYTES

try:
    from compression import zstd  # type: ignore[import-not-found]
except ImportError:
    from backports import zstd  # type: ignore[import-not-found,no-redef]

MB = 1 << 20


def _recording_files() -> ModuleType:
    name = "objrec_tests_recording_files"
    if name not in sys.modules:
        path = Path(__file__).resolve().parents[1] / "hostile" / "recording_files.py"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


rf = _recording_files()


@pytest.fixture
def small_limits(monkeypatch: pytest.MonkeyPatch) -> None:
    """Chunks and messages up to 4 MiB, ROS 2 temp space up to 8 MiB."""
    monkeypatch.setenv("OBJREC_MAX_RECORDING_CHUNK_BYTES", str(4 * MB))
    monkeypatch.setenv("OBJREC_MAX_RECORDING_TEMP_BYTES", str(8 * MB))


# -- inflate ---------------------------------------------------------------------------------------------------
COMPRESS = {"bz2": bz2.compress, "lz4": lz4.frame.compress, "zstd": zstd.compress,
            "zstd-stream": lambda d: rf.streamed_zstd(d)}


@pytest.mark.parametrize("codec", sorted(COMPRESS))
def test_inflate_gives_the_data_of_every_codec_and_of_concatenated_frames(codec: str) -> None:
    data = np.random.default_rng(1).integers(0, 255, 100_000, dtype=np.uint8).tobytes()
    packed = COMPRESS[codec](data)
    codec = codec.split("-")[0]
    assert inflate(packed, codec) == data
    assert inflate(packed + packed, codec) == data + data  # two streams or frames, as rosbag writers may append
    assert inflate(packed, codec, declared=len(data)) == data


@pytest.mark.parametrize("codec", ["bz2", "lz4", "zstd-stream"])
def test_inflate_stops_at_the_limit_without_producing_the_rest(codec: str, monkeypatch) -> None:
    monkeypatch.setenv(RECORDING_CHUNK_BYTES.variable, str(MB))
    packed = COMPRESS[codec](bytes(64 * MB))
    codec = codec.split("-")[0]
    with pytest.raises(InflateError) as caught:
        inflate(packed, codec, what=f"a {codec} chunk")
    assert caught.value.claimed == MB + 1  # one byte past the limit was produced, never the 64 MiB
    assert f"a {codec} chunk, inflated: 1,048,577 bytes, over the limit of 1,048,576 bytes" in str(caught.value)
    assert "OBJREC_MAX_RECORDING_CHUNK_BYTES" in str(caught.value)


def test_inflate_refuses_a_declared_size_past_the_limit_before_inflating(monkeypatch) -> None:
    monkeypatch.setenv(RECORDING_CHUNK_BYTES.variable, str(MB))
    with pytest.raises(InflateError, match="declared: 3,221,225,472 bytes"):
        inflate(b"not even zstd", "zstd", declared=3 << 30)
    frames = zstd.compress(bytes(MB)) * 3  # three frames, each declaring 1 MiB: 3 MiB before inflating any
    with pytest.raises(InflateError, match="its frames declare: 3,145,728 bytes"):
        inflate(frames, "zstd")
    assert zstd_declared(frames) == 3 * MB and zstd_declared(rf.streamed_zstd(bytes(10))) is None


def test_inflate_refuses_more_than_declared_and_a_truncated_stream() -> None:
    packed = zstd.compress(bytes(10_000))
    with pytest.raises(DeclaredSizeError, match="more than the 100 bytes it declares"):
        inflate(packed, "zstd", declared=100)
    with pytest.raises(DeclaredSizeError, match="truncated"):
        inflate(bz2.compress(bytes(10_000))[:-10], "bz2")


# -- bombs in recordings ---------------------------------------------------------------------------------------
def _read_all(path: Path) -> int:
    with open_recording(path) as recording:
        topic = recording.topics()[0].name
        return sum(1 for _ in recording.messages(topic))


@pytest.mark.parametrize(("name", "make"), [
    ("ros1-bz2-declaring-it", lambda p: rf.ros1_chunk_bomb(p / "b.bag", "bz2", 64 * MB, declare=64 * MB)),
    ("ros1-lz4-declaring-it", lambda p: rf.ros1_chunk_bomb(p / "b.bag", "lz4", 64 * MB, declare=64 * MB)),
    ("mcap-zstd-declaring-it", lambda p: rf.mcap_chunk_bomb(p / "b.mcap", "zstd", 64 * MB, declare=64 * MB)),
    ("ros2-message-zstd", lambda p: rf.message_bomb(p / "bag", 64 * MB)),
    ("ros2-message-zstd-streamed", lambda p: rf.message_bomb(p / "bag", 64 * MB, "zstd-stream")),
])
def test_a_compression_bomb_is_one_recording_error_naming_the_limit(tmp_path, small_limits, name, make) -> None:
    path = make(tmp_path)
    with pytest.raises(RecordingError) as caught:
        _read_all(path)
    text = str(caught.value)
    assert text.startswith(str(path)) and "\n" not in text
    assert "over the limit of 4,194,304 bytes (set OBJREC_MAX_RECORDING_CHUNK_BYTES to raise it)" in text


@pytest.mark.parametrize("codec", ["zstd-stream", "lz4"])
def test_an_mcap_chunk_inflating_past_its_declared_size_is_refused(tmp_path, small_limits, codec) -> None:
    path = rf.mcap_chunk_bomb(tmp_path / "b.mcap", codec, 64 * MB)
    with pytest.raises(RecordingError, match=r"corrupt: a \w+ chunk inflates to more than the [\d,]+ bytes"):
        _read_all(path)


@pytest.mark.parametrize("codec", ["bz2", "lz4"])
def test_a_ros1_chunk_inflating_past_its_declared_size_is_refused(tmp_path, small_limits, codec) -> None:
    path = rf.ros1_chunk_bomb(tmp_path / "b.bag", codec, 64 * MB)
    with pytest.raises(RecordingError, match=rf"corrupt: a {codec} chunk inflates to more than the [\d,]+ bytes"):
        _read_all(path)
    path = rf.ros1_chunk_bomb(tmp_path / "c.bag", codec, 64 * MB, declare=2 * MB)  # under the limit, a lie
    with pytest.raises(RecordingError, match="more than the 2,097,152 bytes it declares"):
        _read_all(path)


def test_the_same_recordings_within_the_limits_are_read(tmp_path, small_limits) -> None:
    """Not every compressed recording is refused: the real chunk of a bomb's kind, without the zeros."""
    store, messages = rf.image_messages(True)
    from rosbags.rosbag1 import Writer as Writer1

    for codec in ("bz2", "lz4"):
        path = tmp_path / f"{codec}.bag"
        writer = Writer1(path)
        writer.set_compression(Writer1.CompressionFormat[codec.upper()])
        with writer:
            connection = writer.add_connection("/camera/image", rf.IMAGE, typestore=store)
            for stamp, raw in messages:
                writer.write(connection, stamp, raw)
        assert _read_all(path) == 2


def test_a_file_compressed_bag_is_checked_for_its_temp_space_first(tmp_path, small_limits, monkeypatch) -> None:
    folder = rf.file_bomb(tmp_path / "bag", 64 * MB)
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setenv("TMPDIR", str(temp))
    monkeypatch.setattr("tempfile.tempdir", None)
    with pytest.raises(RecordingError, match=r"storage files, inflated: [\d,]+ bytes, over the limit of 8,388,608"):
        open_recording(folder)
    assert list(temp.iterdir()) == []  # nothing was expanded into the temp folder


def test_a_file_compressed_bag_within_the_limit_is_read(tmp_path, small_limits) -> None:
    folder = rf.file_bomb(tmp_path / "bag", 0)  # the real file and one 40 MiB run: over 8 MiB
    real = tmp_path / "real"
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    store, messages = rf.image_messages(False)
    writer = Writer2(real, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
    with writer:
        connection = writer.add_connection("/camera/image", rf.IMAGE, typestore=store)
        for stamp, raw in messages:
            writer.write(connection, stamp, raw)
    assert check_temp_space(list(real.glob("*.zstd"))) > 0
    assert _read_all(real) == 2
    with pytest.raises(RecordingError):
        open_recording(folder)


def test_free_temp_space_bounds_a_file_compressed_bag(tmp_path, monkeypatch) -> None:
    import objrec_ros.bounded as bounded

    folder = rf.file_bomb(tmp_path / "bag", 0)
    monkeypatch.setattr(bounded.shutil, "disk_usage", lambda _: type("U", (), {"free": 70 * MB})())
    with pytest.raises(RecordingError, match=r"bytes, more than the [\d,]+ bytes free in .*set TMPDIR"):
        open_recording(folder)


# -- definitions and metadata that lie --------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["ros1", "mcap-file"])
def test_an_image_defined_with_a_string_height_is_one_line(tmp_path, fmt) -> None:
    path = rf.image_with_string_height(tmp_path / ("i.bag" if fmt == "ros1" else "i.mcap"), fmt)
    with pytest.raises(RecordingError) as caught:
        _read_all(path)
    assert str(caught.value) == (f"{path}: topic /camera/image: the recording defines sensor_msgs/msg/Image unlike "
                                 "the standard type: height: declared string, standard uint32")


@pytest.mark.parametrize("fmt", ["ros1", "mcap-file"])
def test_a_cloud_defined_with_string_fields_is_one_line(tmp_path, fmt) -> None:
    path = rf.cloud_with_string_fields(tmp_path / ("c.bag" if fmt == "ros1" else "c.mcap"), fmt)
    with pytest.raises(RecordingError, match="fields: declared string, standard sensor_msgs/PointField"):
        _read_all(path)


@pytest.mark.parametrize(("old", "new", "field"), [
    ("\n  message_count: 2\n", "\n  message_count: lots\n", "rosbag2_bagfile_information.message_count: 'lots'"),
    ("    message_count: 2", "    message_count: -3", "files[0].message_count: -3: out of range"),
    ("  version: 9", "  version: nine", "version: 'nine': not a whole number"),
    ("    nanoseconds: 100000000\n  files", "    nanos: 1\n  files", "duration.nanoseconds: missing: required"),
    ("      name: /camera/image", "      name: [1, 2]", "topic_metadata.name: [1, 2]: not text"),
])
def test_metadata_of_the_wrong_kind_is_one_line_naming_field_and_value(tmp_path, old, new, field) -> None:
    folder = rf.edit_metadata(rf.plain_bag_folder(tmp_path / "bag"), old, new)
    with pytest.raises(RecordingError) as caught:
        open_recording(folder)
    text = str(caught.value)
    assert text.startswith(f"{folder}: metadata.yaml: ") and field in text and "\n" not in text


def test_check_metadata_accepts_what_rosbags_writes(tmp_path) -> None:
    from strictio import read_yaml

    folder = rf.plain_bag_folder(tmp_path / "bag")
    check_metadata(read_yaml(folder / "metadata.yaml")["rosbag2_bagfile_information"])
    with pytest.raises(MetadataError, match="message_count: True: not a whole number"):
        check_metadata({**read_yaml(folder / "metadata.yaml")["rosbag2_bagfile_information"], "message_count": True})


# -- one timeline, compressed output ----------------------------------------------------------------------------
def test_origins_find_a_frame_by_stamp_and_forget_the_frames_before_it() -> None:
    origins = Origins()
    for i in range(5):
        origins.add(Origin(100 + i, 1000 + i, 0 if i == 2 else 100 + i, f"f{i}"))
    assert origins.take(102) == Origin(102, 1002, 0, "f2")
    assert origins.take(100) is None  # before the one taken: dropped
    assert origins.take(104) == Origin(104, 1004, 104, "f4")


class _Array(DetectedObjectArray):
    """An array with no objects: only its header matters here."""

    ros_type = "test_msgs/msg/Objects"
    ros_definitions = {"test_msgs/msg/Objects": "std_msgs/Header header\nstring[] objects\n"}  # noqa: RUF012


def _image_bag(path: Path, stamps: list[int], frame_id: str) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    from rosbags.rosbag1 import Writer as Writer1

    types = store.types
    with Writer1(path) as writer:
        connection = writer.add_connection("/image", rf.IMAGE, typestore=store)
        for i, stamp in enumerate(stamps):
            time = types["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
            header = types["std_msgs/msg/Header"](seq=i, stamp=time, frame_id=frame_id)
            message = types[rf.IMAGE](header=header, height=1, width=1, encoding="bgr8", is_bigendian=0, step=3,
                                      data=np.zeros(3, dtype=np.uint8))
            writer.write(connection, rf.START_NS + i * 10**9, store.serialize_ros1(message, rf.IMAGE))
    return path


@pytest.mark.parametrize(("stamps", "frame_id"), [([0, 0], ""), ([5 * 10**9, 6 * 10**9], "lidar")])
def test_detections_are_logged_beside_their_inputs_under_their_headers(tmp_path, stamps, frame_id) -> None:
    """The input's header stamps may be 0 or far from its log times; the detections follow the input."""
    bag = _image_bag(tmp_path / "in.bag", stamps, frame_id)
    origins = Origins()
    for i, stamp in enumerate(stamps):
        log = rf.START_NS + i * 10**9
        origins.add(Origin(stamp or log, log, stamp, frame_id))
    out = tmp_path / "out.mcap"
    with open_detection_writer(out, _Array, "/objects", copy_from=InputCopy(bag, ("/image",), origins=origins)) as w:
        for i, stamp in enumerate(stamps):
            frame_stamp = stamp or rf.START_NS + i * 10**9
            w(_Array(header=Header(seq=i, stamp=frame_stamp / 1e9, frame_id=frame_id or "camera",
                                   stamp_ns=frame_stamp)))
    with AnyReader([out]) as reader:
        found: dict[str, list[tuple[int, int, int, str]]] = {}
        for connection, log_time, raw in reader.messages():
            header = reader.deserialize(raw, connection.msgtype).header
            found.setdefault(connection.topic, []).append(
                (log_time, header.stamp.sec, header.stamp.nanosec, header.frame_id))
    assert found["/objects"] == found["/image"]  # same log times, same stamps (0 kept), same frame_id ("" kept)
    assert [t for t, *_ in found["/image"]] == [rf.START_NS, rf.START_NS + 10**9]


def test_mcap_output_chunks_are_compressed_and_read_by_both_readers(tmp_path) -> None:
    out = tmp_path / "out.mcap"
    with open_detection_writer(out, _Array, "/objects") as writer:
        for i in range(200):
            writer(_Array(header=Header(seq=i, stamp=1.0 + i, frame_id="camera")))
    with out.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and {c.compression for c in summary.chunk_indexes} == {"zstd"}
        assert sum(c.compressed_size for c in summary.chunk_indexes) < sum(
            c.uncompressed_size for c in summary.chunk_indexes)
        assert sum(1 for _ in reader.iter_messages()) == 200
    with AnyReader([out]) as reader:
        assert sum(1 for _ in reader.messages()) == 200


def test_the_gui_reads_recordings_through_the_same_bounded_reader(tmp_path, small_limits) -> None:
    """The definition GUI lists a recording's topics (``topic_chooser``) and plays it through ``open_source``,
    the readers objrec-detect uses: a bomb is refused there too, as one SourceError for the status line."""
    from objrec_apps.gui.topic_chooser import recording_topics
    from objrec_core import SourceError, open_source

    file_bomb = rf.file_bomb(tmp_path / "files", 64 * MB)
    assert recording_topics(str(file_bomb)) is None  # not listed; opening it says why
    chunk_bomb = rf.ros1_chunk_bomb(tmp_path / "chunk.bag", "bz2", 64 * MB, declare=64 * MB)
    assert recording_topics(str(chunk_bomb)) == [("/camera/image", rf.IMAGE, 2)]  # the index: no chunk read
    for path in (file_bomb, chunk_bomb):
        with pytest.raises(SourceError, match="OBJREC_MAX_RECORDING_"), open_source(str(path), "2d") as source:
            next(iter(source))


@pytest.mark.parametrize(("order", "gap", "tail", "xyz"), [
    (("x", "y", "z", "rgb"), 0, 0, "float32"),
    (("rgb", "z", "x", "y"), 4, 8, "float32"),
    (("x", "y", "z", "rgb"), 0, 4, "float64"),
])
def test_a_cloud_decoded_in_its_own_buffer_equals_one_decoded_apart(tmp_path, bagmaker, order, gap, tail, xyz):
    """An uncompressed ROS 1 bag's cloud is packed inside the message's buffer (objrec_ros.direct); the points
    and colours must be exactly those of the same message decoded into arrays of their own."""
    from objrec_core import open_source
    from objrec_ros.decode import pointcloud2_arrays

    maker = bagmaker.Messages("ros1")
    rng = np.random.default_rng(5)
    points = rng.uniform(-3, 3, (300_001, 3)).astype(np.float32)  # more than one block of 2**18 points
    colors = rng.integers(0, 255, (300_001, 3), dtype=np.uint8)
    message = maker.cloud(points, colors, rf.START_NS, order=order, gap=gap, tail=tail, xyz=xyz)
    apart = pointcloud2_arrays(message)
    bag = bagmaker.write(tmp_path / "c", "ros1", maker, [bagmaker.Entry("/points", rf.POINT_CLOUD2, rf.START_NS,
                                                                        message)])
    with open_source(str(bag), "3d") as source:
        [frame] = list(source)
    owner = frame.data.points
    while isinstance(owner, np.ndarray) and owner.base is not None:
        owner = owner.base
    assert isinstance(owner.obj if isinstance(owner, memoryview) else owner, bytearray)  # packed in place
    assert np.array_equal(frame.data.points, apart.points) and np.array_equal(frame.data.points, points)
    assert np.array_equal(frame.data.colors, apart.colors) and np.array_equal(frame.data.colors, colors)
    assert np.array_equal(pointcloud2_arrays(message).points, points)  # the caller's message is left as it was
