"""Real recordings made by others (``../shared/data/recordings``): ``--copy-input`` puts the detections beside
their inputs. The lidar bag's header stamps lie 237 days before its log times; the rospy bag's image has stamp 0
and an empty frame_id. Read back with rosbags (and the mcap reader), every detection is logged at its input
message's log time under that message's header, exactly.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rosbags")

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

PROJECT = Path(__file__).resolve().parents[2]
RECORDINGS = PROJECT.parent / "shared" / "data" / "recordings"
LIDAR = RECORDINGS / "embag-test.bag"  # /luminar_pointcloud: stamps in March 2020, log times in November 2020
ROSPY = RECORDINGS / "rosnumpy-test.bag"  # /image: stamp 0, frame_id ""
SHAPE = PROJECT / "params" / "shape_demo.yaml"
HSV = PROJECT / "params" / "hsv_demo.yaml"


def headers(path: Path) -> dict[str, list[tuple[int, int, int, str]]]:
    """(log time, stamp sec, stamp nanosec, frame_id) per topic, as rosbags reads them."""
    found: dict[str, list[tuple[int, int, int, str]]] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.LATEST)) as reader:
        for connection, log_time, raw in reader.messages():
            header = getattr(reader.deserialize(raw, connection.msgtype), "header", None)
            if header is None:  # a Point or a Pose: not an input objrec reads
                continue
            found.setdefault(connection.topic, []).append(
                (log_time, header.stamp.sec, header.stamp.nanosec, header.frame_id))
    return found


@pytest.mark.parametrize(("bag", "params", "topic", "detections"), [
    (LIDAR, SHAPE, "/luminar_pointcloud", "/objrec/shape"),
    (ROSPY, HSV, "/image", "/objrec/coloured_object"),
], ids=["lidar-stamps-237-days-off", "rospy-stamp-0-empty-frame-id"])
def test_copied_inputs_and_detections_share_one_timeline(tmp_path, bag, params, topic, detections) -> None:
    if not bag.is_file():
        pytest.skip(f"{bag} is not here (the shared recordings are not on this machine)")
    out = tmp_path / "replay.mcap"
    result = subprocess.run([sys.executable, "-m", "objrec_apps.detect", str(params), "--source",
                             f"bag:{bag},topic={topic}", "--output", str(out), "--copy-input"],
                            capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    found = headers(out)
    inputs, outputs = found[topic], found[detections]
    assert len(inputs) == len(outputs) == len(headers(bag)[topic]) > 0
    assert outputs == inputs  # same log times, the input's header stamp and frame_id to the nanosecond
    original = headers(bag)[topic]
    assert [(t, s, n, f) for t, s, n, f in inputs] == original  # the copy is the input as recorded
    if bag == LIDAR:
        log_ns, sec, nanosec, _ = original[0]
        assert log_ns - (sec * 10**9 + nanosec) > 200 * 86400 * 10**9  # the stamps really are months off
    else:
        assert original[0][1:] == (0, 0, "")
    with out.open("rb") as stream:
        times = [(channel.topic, message.log_time) for _, channel, message in make_reader(stream).iter_messages()]
    assert sorted(t for c, t in times if c == detections) == [t for t, *_ in inputs]
