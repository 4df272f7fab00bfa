"""Detections out as typed ROS messages: MCAP files, ROS 1 bags and ROS 2 bag folders written by objrec-detect
and objrec_ros.output, read back with nothing but the file (rosbags with a fresh typestore, and the `mcap`
reader), equal to the JSON Lines output field for field; --copy-input, --list-topics and the failures."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

pytest.importorskip("rosbags")

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from objrec_core import DetectedObjectArray, DetectionDirector, Header, build_system, open_source
from objrec_ros.msgdefs import MessageDefinitionError
from objrec_ros.output import InputCopy, open_detection_writer, output_format

DETECT = [sys.executable, "-m", "objrec_apps.detect"]
PEAK_MEMORY = Path(__file__).resolve().parents[1] / "peak_memory.py"
HSV, SHAPE = "params/hsv_demo.yaml", "params/shape_demo.yaml"
RUNS = {HSV: "demo:frames=5", SHAPE: "demo:frames=2"}
TOPICS = {HSV: "/objrec/coloured_object", SHAPE: "/objrec/shape"}
TYPES = {
    HSV: "object_detection_2d_msgs/msg/DetectedObject2DArray",
    SHAPE: "object_detection_3d_msgs/msg/DetectedObject3DArray",
}


def run(args: list[str], cwd: Path, timeout: float = 180, **kwargs: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*DETECT, *args], capture_output=True, text=True, cwd=cwd, timeout=timeout, **kwargs)


# -- reading a file back with nothing but the file ---------------------------------------------------------
def plain(value: Any) -> Any:
    """A decoded rosbags message as plain dicts and lists."""
    if dataclasses.is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value) if f.name != "__msgtype__"}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def fresh_decode(definition: str, msgtype: str, raw: bytes, ros1: bool) -> dict[str, Any]:
    """Decode with a typestore that knows only the standard types plus the definition stored in the file."""
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    assert msgtype not in store.fielddefs or msgtype not in TYPES.values()
    store.register(get_types_from_msg(definition, msgtype))
    message = store.deserialize_ros1(raw, msgtype) if ros1 else store.deserialize_cdr(raw, msgtype)
    return plain(message)


def read_rosbags(path: Path) -> dict[str, list[tuple[int, str, dict[str, Any]]]]:
    """{topic: [(log time, type, message)]} read by rosbags' AnyReader (its typestore starts empty and gets the
    file's definitions only), each message also decoded in a fresh standard typestore: both must agree."""
    found: dict[str, list[tuple[int, str, dict[str, Any]]]] = {}
    with AnyReader([path]) as reader:
        known = set(reader.typestore.fielddefs) - set(get_typestore(Stores.EMPTY).fielddefs)
        assert known <= {n for c in reader.connections for n in get_types_from_msg(c.msgdef.data, c.msgtype)}
        for connection, log_time, raw in reader.messages():
            message = plain(reader.deserialize(raw, connection.msgtype))
            if connection.msgtype in TYPES.values():
                again = fresh_decode(connection.msgdef.data, connection.msgtype, bytes(raw), not reader.is2)
                assert again == message
            found.setdefault(connection.topic, []).append((log_time, connection.msgtype, message))
    return found


def read_mcap(path: Path) -> dict[str, list[tuple[int, str, dict[str, Any]]]]:
    """The same with the independent `mcap` reader: records, schemas (ros2msg) and CDR payloads."""
    found: dict[str, list[tuple[int, str, dict[str, Any]]]] = {}
    with path.open("rb") as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == "ros2"
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            decoded = fresh_decode(schema.data.decode(), schema.name, message.data, ros1=False)
            found.setdefault(channel.topic, []).append((message.log_time, schema.name, decoded))
    return found


def _declares_truncated() -> bool:
    """Whether the 2D object message has the ``truncated`` flag (a JSON line leaves it out when False)."""
    from objrec2d.messages import DetectedObject2DArray

    return any("truncated" in text for text in DetectedObject2DArray.ros_definitions.values())


_TRUNCATED_2D = _declares_truncated()


def expected(line: dict[str, Any], ros1: bool) -> dict[str, Any]:
    """A JSON line as the typed message holds it: ROS names for the stamp, no seq in ROS 2, the ROS defaults
    of fields a JSON line leaves out (a 3D object without a shape fit), Point32 coordinates as float32."""
    header = line["header"]
    typed_header = {"stamp": {"sec": header["stamp"]["secs"], "nanosec": header["stamp"]["nsecs"]},
                    "frame_id": header["frame_id"]}
    if ros1:
        typed_header = {"seq": header["seq"], **typed_header}
    objects = []
    for obj in line["objects"]:
        if "polygon" in obj:
            points = [{k: float(np.float32(v)) for k, v in p.items()} for p in obj["polygon"]["points"]]
            flags = {"truncated": bool(obj.get("truncated", False))} if _TRUNCATED_2D else {}
            objects.append({"name": obj["name"], "polygon": {"points": points}, **flags})
        else:
            objects.append({"shape": "", "radius": 0.0, "inliers": 0, **obj})
    return {"header": typed_header, "objects": objects}


def log_time_of(line: dict[str, Any]) -> int:
    return line["header"]["stamp"]["secs"] * 1_000_000_000 + line["header"]["stamp"]["nsecs"]


def the_file(path: Path) -> Path:
    """The MCAP file of an output: the file itself, or the storage file in a ROS 2 bag folder."""
    return path if path.is_file() else next(path.glob("*.mcap"))


# -- detections written in process: the same arrays go to JSON Lines and to the typed file ------------------
@pytest.mark.parametrize(("params", "suffix"), [(HSV, ".mcap"), (HSV, ".bag"), (HSV, ""), (SHAPE, ".mcap"),
                                                (SHAPE, ".bag")])
def test_typed_messages_equal_the_json_lines_and_carry_the_frame_stamps(project_root, tmp_path, params, suffix):
    system = build_system(project_root / params)
    frame_stamps: list[float] = []
    json_lines: list[dict[str, Any]] = []
    out = tmp_path / f"detections{suffix}"
    with open_detection_writer(out, system.object_array_type, TOPICS[params]) as writer:
        director = DetectionDirector(system, sinks=[lambda a: json_lines.append(json.loads(a.to_json())), writer],
                                     annotation_sinks=[lambda frame, _a, _s: frame_stamps.append(frame.stamp)])
        director.run_all(open_source(RUNS[params], system.kind))
    assert writer.count == len(json_lines) == len(frame_stamps) == int(RUNS[params].split("=")[1])
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]  # no temporary left beside it
    ros1 = suffix == ".bag"
    readers = [read_rosbags(out)] + ([] if ros1 else [read_mcap(the_file(out))])
    for found in readers:
        assert list(found) == [TOPICS[params]]
        messages = found[TOPICS[params]]
        assert [m[1] for m in messages] == [TYPES[params]] * len(json_lines)
        for (log_time, _, message), line, stamp in zip(messages, json_lines, frame_stamps, strict=True):
            assert message == expected(line, ros1)  # field for field
            assert ("seq" in message["header"]) is ros1
            assert log_time == log_time_of(line)
            assert Header(stamp=stamp).to_dict()["stamp"] == line["header"]["stamp"]  # the frame's own stamp
            assert abs(log_time / 1e9 - stamp) < 1e-6
    if params == HSV:
        assert sum(len(m[2]["objects"]) for m in readers[0][TOPICS[HSV]]) == 20
    else:
        shapes = [o["shape"] for m in readers[0][TOPICS[SHAPE]] for o in m[2]["objects"]]
        assert sorted(shapes) == ["cylinder", "cylinder", "sphere", "sphere"]


def test_a_ros2_bag_folder_has_metadata_that_names_the_topic_and_count(project_root, tmp_path):
    system = build_system(project_root / HSV)
    out = tmp_path / "bagfolder"
    out.mkdir()  # an empty folder becomes the bag
    with open_detection_writer(out, system.object_array_type, "/found") as writer:
        DetectionDirector(system, sinks=[writer]).run_all(open_source("demo:frames=3", "2d"))
    assert sorted(p.name for p in out.iterdir()) == ["bagfolder.mcap", "metadata.yaml"]
    with AnyReader([out]) as reader:
        assert reader.message_count == 3
        assert {c.topic: c.msgtype for c in reader.connections} == {"/found": TYPES[HSV]}


# -- objrec-detect end to end ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def json_runs(project_root) -> dict[str, list[dict[str, Any]]]:
    """The JSON Lines of each demo run (the demo scenes are the same every run; only the stamps differ)."""
    lines = {}
    for params, source in RUNS.items():
        result = run([params, "-s", source], project_root)
        assert result.returncode == 0, result.stderr
        lines[params] = [json.loads(line) for line in result.stdout.splitlines()]
    return lines


def without_stamp(message: dict[str, Any]) -> dict[str, Any]:
    return {**message, "header": {k: v for k, v in message["header"].items() if k != "stamp"}}


@pytest.mark.parametrize(("params", "suffix"), [(HSV, ".mcap"), (HSV, ".bag"), (SHAPE, ".mcap"), (SHAPE, ".bag")])
def test_detect_writes_typed_messages_equal_to_its_json_lines(project_root, tmp_path, json_runs, params, suffix):
    out = tmp_path / f"found{suffix}"
    started = time.time()
    result = run([params, "-s", RUNS[params], "--output", str(out)], project_root)
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""
    count = len(json_runs[params])
    assert f"{count} messages on {TOPICS[params]} written to {out}" in result.stderr
    ros1 = suffix == ".bag"
    for found in [read_rosbags(out)] + ([] if ros1 else [read_mcap(out)]):
        messages = found[TOPICS[params]]
        assert len(messages) == count
        for (log_time, _, message), line in zip(messages, json_runs[params], strict=True):
            assert without_stamp(message) == without_stamp(expected(line, ros1))
            stamp = message["header"]["stamp"]
            assert log_time == stamp["sec"] * 1_000_000_000 + stamp["nanosec"]
            assert started - 1 < log_time / 1e9 < time.time() + 1  # the demo stamps its frames when made
        assert [m[0] for m in messages] == sorted(m[0] for m in messages)


def test_output_topic_and_a_folder_output(project_root, tmp_path):
    out = tmp_path / "run1"
    result = run([HSV, "-s", "demo:frames=2", "-o", str(out), "--output-topic", "robot/cam/objects",
                  "--frame-id", "head_cam"], project_root)
    assert result.returncode == 0, result.stderr
    assert (out / "metadata.yaml").is_file()
    messages = read_rosbags(out)["/robot/cam/objects"]
    assert [m[2]["header"]["frame_id"] for m in messages] == ["head_cam", "head_cam"]
    # the same folder again: the earlier bag is replaced, not refused or mixed in
    result = run([HSV, "-s", "demo:frames=3", "-o", str(out)], project_root)
    assert result.returncode == 0, result.stderr
    assert list(read_rosbags(out)) == ["/objrec/coloured_object"]
    assert len(read_rosbags(out)["/objrec/coloured_object"]) == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run1"]


def test_a_stop_signal_leaves_a_complete_file(project_root, tmp_path):
    out = tmp_path / "endless.mcap"
    process = subprocess.Popen([*DETECT, HSV, "-s", "demo", "-o", str(out)], cwd=project_root,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 180  # a hang guard, never a speed bound
    while not list(tmp_path.glob(".endless.mcap.*.tmp")):  # the writer is open (and the handlers are set)
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    messages = read_mcap(out)["/objrec/coloured_object"]
    assert len(messages) >= 1 and f"{len(messages)} messages on" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["endless.mcap"]


# -- a kind's own array class: the writer only knows its definitions ---------------------------------------
@dataclass
class Reading:
    label: str
    values: list[float] = field(default_factory=list)
    corners: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    flags: list[int] = field(default_factory=list)
    count: int = 0
    tags: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass
class ReadingArray(DetectedObjectArray):
    object_type = Reading
    ros_type: ClassVar[str] = "signal_msgs/msg/ReadingArray"
    ros_definitions: ClassVar[dict[str, str]] = {
        "signal_msgs/msg/ReadingArray": "std_msgs/Header header\nReading[] objects\n",
        "signal_msgs/msg/Reading": "string label\nfloat32[] values\nfloat64[3] corners\nuint8[] flags\n"
                                   "int64 count\nstring[] tags\n",
    }


@pytest.mark.parametrize("suffix", [".mcap", ".bag"])
def test_a_third_kinds_array_is_written_from_its_definitions(tmp_path, suffix):
    arrays = [
        ReadingArray(Header(seq=i, stamp=1_700_000_000.25 + i, frame_id="probe"),
                     [Reading("a", [0.5, 1.5 * i], [1.0, 2.0, 3.0 + i], [1, 255], -7 * i, ["x", "y"]), Reading("b")])
        for i in range(3)
    ]
    out = tmp_path / f"readings{suffix}"
    with open_detection_writer(out, ReadingArray, "/signal/readings") as writer:
        for array in arrays:
            writer(array)
    found = read_rosbags(out)["/signal/readings"]
    assert [m[0] for m in found] == [1_700_000_000_250_000_000 + i * 1_000_000_000 for i in range(3)]
    for (_, msgtype, message), array in zip(found, arrays, strict=True):
        assert msgtype == "signal_msgs/msg/ReadingArray"
        assert message["objects"] == [o.to_dict() for o in array.objects]
        assert message["header"]["frame_id"] == "probe"


def test_a_field_the_definition_lacks_is_refused(tmp_path):
    @dataclass
    class Loose:
        label: str
        surprise: int = 1

        def to_dict(self) -> dict[str, Any]:
            return dataclasses.asdict(self)

    out = tmp_path / "loose.mcap"
    writer = open_detection_writer(out, ReadingArray, "/t")
    refused = r"objects\[0\]: signal_msgs/msg/Reading has no field surprise"
    with pytest.raises(MessageDefinitionError, match=refused), writer:
        writer(ReadingArray(Header(), [Loose("a")]))
    assert list(tmp_path.iterdir()) == []  # the failed output left nothing


def test_output_format_by_path(tmp_path):
    from objrec_apps.outputs import is_typed_output

    (tmp_path / "existing").mkdir()
    (tmp_path / "plain").write_text("")
    cases = {"a.mcap": "mcap", "a.MCAP": "mcap", "b.bag": "ros1", "newfolder": "ros2", "existing": "ros2",
             "plain": None, "x.jsonl": None, "x.json": None, "x.txt": None}
    for name, fmt in cases.items():
        assert output_format(tmp_path / name) == fmt, name
        assert is_typed_output(str(tmp_path / name)) == (fmt is not None), name
    assert output_format("/dev/full") is None


def test_default_topics_are_valid_ros_names():
    from objrec_apps.cli import UserError
    from objrec_apps.outputs import check_topic, default_topic

    assert default_topic("coloured_object") == "/objrec/coloured_object"
    assert default_topic("red cup #2") == "/objrec/red_cup_2"
    assert default_topic("3d-box") == "/objrec/object_3d_box"
    assert default_topic("__") == "/objrec/objects"
    assert check_topic("robot/objects") == "/robot/objects"
    for bad in ("/a//b", "/a/", "/9lives", "/a b", "/a__b", ""):
        with pytest.raises(UserError, match="not a valid ROS topic name"):
            check_topic(bad)


# -- a bag as input: --copy-input and --list-topics ----------------------------------------------------------
BAG_STAMP = 1_700_000_000.0


def write_image_bag(path: Path, frames: int, ros1: bool) -> list[float]:
    """The 2D demo's frames as sensor_msgs/Image (bgr8) on /camera/image_raw plus a /chatter topic, written with
    rosbags; returns the header stamps (log times 5 ms later, as a recorder logs them)."""
    from objrec2d import DemoSource

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    image_type, header_type, time_type, string_type = (
        store.types[n] for n in ("sensor_msgs/msg/Image", "std_msgs/msg/Header", "builtin_interfaces/msg/Time",
                                 "std_msgs/msg/String")
    )
    stamps = []
    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        images = writer.add_connection("/camera/image_raw", "sensor_msgs/msg/Image", typestore=store)
        chatter = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        for index, frame in enumerate(DemoSource(frames=frames)):
            stamp = BAG_STAMP + index * 0.1 + 0.000_000_123
            stamps.append(stamp)
            sec = int(stamp)
            nanosec = round((stamp - sec) * 1e9)
            seq = {"seq": index} if ros1 else {}
            header = header_type(**seq, stamp=time_type(sec, nanosec), frame_id="camera_optical")
            height, width = frame.data.shape[:2]
            message = image_type(header, height, width, "bgr8", 0, width * 3, frame.data.reshape(-1).copy())
            raw = store.serialize_ros1(message, "sensor_msgs/msg/Image") if ros1 else \
                store.serialize_cdr(message, "sensor_msgs/msg/Image")
            log_time = sec * 1_000_000_000 + nanosec + 5_000_000
            writer.write(images, log_time, raw)
            text = string_type(f"frame {index}")
            writer.write(chatter, log_time + 1, store.serialize_ros1(text, "std_msgs/msg/String") if ros1 else
                         store.serialize_cdr(text, "std_msgs/msg/String"))
    return stamps


@pytest.fixture(scope="module")
def image_bags(tmp_path_factory) -> dict[str, tuple[Path, list[float]]]:
    folder = tmp_path_factory.mktemp("bags")
    return {
        "ros1": (folder / "images.bag", write_image_bag(folder / "images.bag", 4, ros1=True)),
        "ros2": (folder / "images_ros2", write_image_bag(folder / "images_ros2", 4, ros1=False)),
    }


def bag_source_available() -> bool:
    try:
        open_source("missing.bag", "2d")
    except Exception as exc:
        return "no source" not in str(exc) and "cannot be loaded" not in str(exc)
    return True


needs_bag_source = pytest.mark.skipif(not bag_source_available(), reason="the 2d bag source is not there yet")


@needs_bag_source
@pytest.mark.parametrize(("bag", "suffix"), [("ros1", ".mcap"), ("ros1", ".bag"), ("ros2", ".mcap"),
                                             ("ros2", ".bag")])
def test_copy_input_gives_both_topics_and_the_detections_carry_the_bag_stamps(project_root, tmp_path, image_bags,
                                                                               bag, suffix):
    source, stamps = image_bags[bag]
    out = tmp_path / f"replay{suffix}"
    result = run([HSV, "-s", str(source), "-o", str(out), "--copy-input"], project_root)
    assert result.returncode == 0, result.stderr
    lines = run([HSV, "-s", str(source)], project_root)
    assert lines.returncode == 0, lines.stderr
    json_lines = [json.loads(line) for line in lines.stdout.splitlines()]
    ros1 = suffix == ".bag"
    for found in [read_rosbags(out)] + ([] if ros1 else [read_mcap(out)]):
        assert sorted(found) == ["/camera/image_raw", "/objrec/coloured_object"]  # /chatter was not read: not copied
        detections, images = found["/objrec/coloured_object"], found["/camera/image_raw"]
        assert len(detections) == len(images) == len(json_lines) == 4
        for (log_time, _, message), line, stamp, (image_time, _, _) in zip(detections, json_lines, stamps, images,
                                                                          strict=True):
            assert message == expected(line, ros1)  # field for field, stamps included: they come from the bag
            header_stamp = message["header"]["stamp"]
            assert abs(header_stamp["sec"] + header_stamp["nanosec"] / 1e9 - stamp) < 1e-6
            assert log_time == image_time  # one timeline: the detection is logged when its input message was
            assert line["header"]["frame_id"] == "camera_optical"
        with AnyReader([source]) as reader:
            originals = [plain(reader.deserialize(raw, c.msgtype))
                         for c, _, raw in reader.messages([c for c in reader.connections if c.topic ==
                                                           "/camera/image_raw"])]
            original_times = [t for c, t, _ in reader.messages() if c.topic == "/camera/image_raw"]
        assert [m[0] for m in images] == original_times
        for (_, _, detection), (_, _, image) in zip(detections, images, strict=True):
            assert detection["header"]["stamp"] == image["header"]["stamp"]  # to the nanosecond: pairable in ROS
        for (_, msgtype, image), original in zip(images, originals, strict=True):
            assert msgtype == "sensor_msgs/msg/Image"
            assert image["data"] == original["data"] and image["encoding"] == "bgr8"
            assert image["header"]["stamp"] == original["header"]["stamp"]
            assert ("seq" in image["header"]) is ros1  # re-serialised between ROS 1 and ROS 2 where needed
        times = [t for topic in found.values() for t, _, _ in topic]
        assert len(times) == 8
    if not ros1:  # the MCAP file holds the input's messages in log-time order with the detections
        with out.open("rb") as stream:
            order = [m.log_time for _, _, m in make_reader(stream).iter_messages(log_time_order=False)]
        assert order == sorted(order)


@needs_bag_source
def test_copy_input_with_a_start_window(project_root, tmp_path, image_bags):
    source, stamps = image_bags["ros1"]
    out = tmp_path / "window.mcap"
    result = run([HSV, "-s", f"bag:{source},start=0.15", "-o", str(out), "--copy-input"], project_root)
    assert result.returncode == 0, result.stderr
    found = read_mcap(out)
    assert len(found["/camera/image_raw"]) == len(found["/objrec/coloured_object"]) == 2
    detections, images = found["/objrec/coloured_object"], found["/camera/image_raw"]
    assert [m[0] for m in detections] == [m[0] for m in images]  # logged beside their inputs
    header_stamps = [m[2]["header"]["stamp"] for m in detections]
    assert [round(h["sec"] + h["nanosec"] / 1e9, 3) for h in header_stamps] == [round(s, 3) for s in stamps[2:]]


@needs_bag_source
def test_copy_input_onto_the_input_topic_is_refused(project_root, tmp_path, image_bags):
    source, _ = image_bags["ros1"]
    out = tmp_path / "same.mcap"
    result = run([HSV, "-s", str(source), "-o", str(out), "--copy-input", "--output-topic", "/camera/image_raw"],
                 project_root)
    assert result.returncode == 2
    assert "topic /camera/image_raw would hold both the input and the detections" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_list_topics_prints_the_table(project_root, image_bags, tmp_path):
    source, _ = image_bags["ros2"]
    result = run(["--list-topics", str(source)], project_root)
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines()]
    assert rows[0] == ["topic", "type", "messages"]
    assert rows[1:3] == [["/camera/image_raw", "sensor_msgs/msg/Image", "4"], ["/chatter", "std_msgs/msg/String", "4"]]
    assert "ROS 2 bag (mcap)" in result.stdout and "8 messages" in result.stdout
    result = run(["--list-topics", f"bag:{image_bags['ros1'][0]}"], project_root)
    assert result.returncode == 0, result.stderr
    assert "ROS 1 bag, 2 topics, 8 messages" in result.stdout
    missing = run(["--list-topics", str(tmp_path / "none.bag")], project_root)
    assert missing.returncode == 2 and missing.stdout == ""
    assert missing.stderr.strip() == f"objrec-detect: error: {tmp_path / 'none.bag'}: ROS 1 bag not found"


# -- failures: one line, exit 2, nothing half written ---------------------------------------------------------
def assert_one_line_error(result: subprocess.CompletedProcess[str], fragment: str) -> None:
    assert result.returncode == 2, result.stderr
    assert fragment in result.stderr
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_copy_input_needs_a_bag_source_and_a_typed_output(project_root, tmp_path):
    result = run([HSV, "-s", "demo:frames=1", "-o", str(tmp_path / "a.mcap"), "--copy-input"], project_root)
    assert_one_line_error(result, "--copy-input: the source 'demo:frames=1' is not a bag")
    result = run([HSV, "-s", "demo:frames=1", "-o", str(tmp_path / "a.jsonl"), "--copy-input"], project_root)
    assert_one_line_error(result, "--copy-input needs a typed --output")
    result = run([HSV, "-s", "demo:frames=1", "--output-topic", "/x"], project_root)
    assert_one_line_error(result, "--output-topic needs a typed --output")
    result = run([HSV, "-s", "demo:frames=1", "-o", str(tmp_path / "a.mcap"), "--output-topic", "/bad topic"],
                 project_root)
    assert_one_line_error(result, "--output-topic '/bad topic': not a valid ROS topic name")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_a_read_only_folder_is_one_error_line(project_root, tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        result = run([HSV, "-s", "demo:frames=1", "-o", str(folder / "out.mcap")], project_root)
        assert_one_line_error(result, f"{folder / 'out.mcap'}: cannot be written: Permission denied")
        assert list(folder.iterdir()) == []
    finally:
        folder.chmod(0o700)


@pytest.mark.parametrize("name", ["out.mcap", "out.bag", "outfolder"])
def test_an_unwritable_place_is_one_error_line(project_root, tmp_path, name):
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file where a folder would go")
    result = run([HSV, "-s", "demo:frames=1", "-o", str(blocker / name)], project_root)
    assert_one_line_error(result, f"{blocker / name}: cannot be written: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["not_a_folder"]


def test_a_folder_holding_other_files_is_not_replaced(project_root, tmp_path):
    folder = tmp_path / "photos"
    folder.mkdir()
    (folder / "holiday.png").write_bytes(b"not a bag")
    result = run([HSV, "-s", "demo:frames=1", "-o", str(folder)], project_root)
    assert_one_line_error(result, f"{folder}: is a folder holding other files than a ROS 2 bag")
    assert [p.name for p in folder.iterdir()] == ["holiday.png"]


def full_disk(args: list[str], limit: int) -> list[str]:
    """``args`` run with every file limited to ``limit`` bytes (writes past it fail with EFBIG), the limit set
    by tests/peak_memory.py in its own fork: a ``preexec_fn`` here would run Python between fork and exec in
    this process, which has threads once rerun-sdk is imported, and can deadlock the child."""
    report = Path(tempfile.mkdtemp(prefix="peak-")) / "peak"
    return [sys.executable, str(PEAK_MEMORY), "--file-size-limit", str(limit), str(report), *args]


@pytest.mark.parametrize("name", ["full.mcap", "full.bag"])
def test_a_write_that_fails_midway_leaves_the_earlier_file_untouched(project_root, tmp_path, name):
    out = tmp_path / name
    out.write_bytes(b"an earlier output")
    result = subprocess.run(full_disk([*DETECT, HSV, "-s", "demo:frames=5", "-o", str(out)], 4096),
                            capture_output=True, text=True, cwd=project_root, timeout=180)
    assert_one_line_error(result, f"{out}: cannot be written: File too large")
    assert out.read_bytes() == b"an earlier output"
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_without_rosbags_the_options_name_the_extra(project_root, tmp_path):
    blocked = ("import sys; sys.modules['rosbags'] = None; from objrec_apps.detect import main; "
               "sys.exit(main(sys.argv[1:]))")
    for args, option in (([HSV, "-s", "demo:frames=1", "-o", str(tmp_path / "x.mcap")], f"--output {tmp_path}/x.mcap"),
                         (["--list-topics", "some.bag"], "--list-topics")):
        result = subprocess.run([sys.executable, "-c", blocked, *args], capture_output=True, text=True,
                                cwd=project_root, timeout=120)
        assert result.returncode == 2
        assert result.stderr.strip().endswith(f"{option} needs rosbags, which is not installed: "
                                              "pip install 'objrec[ros]'")
        assert "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []
    # JSON Lines output still works without it
    args = [HSV, "-s", "demo:frames=1", "-o", str(tmp_path / "x.jsonl")]
    result = subprocess.run([sys.executable, "-c", blocked, *args], capture_output=True, text=True,
                            cwd=project_root, timeout=120)
    assert result.returncode == 0, result.stderr
    assert len((tmp_path / "x.jsonl").read_text().splitlines()) == 1


def test_copy_from_a_missing_topic_is_refused_by_the_writer(tmp_path, image_bags):
    source, _ = image_bags["ros1"]
    from objrec2d.messages import DetectedObject2DArray

    with pytest.raises(Exception, match=r"has no topic /nothing to copy \(topics: /camera/image_raw, /chatter\)"):
        open_detection_writer(tmp_path / "x.mcap", DetectedObject2DArray, "/found",
                              copy_from=InputCopy(source, ("/nothing",)))
    assert list(tmp_path.iterdir()) == []
