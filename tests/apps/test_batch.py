"""objrec-batch end to end on a local Dask cluster: one output per source, the summary, a corrupt recording
reported and not fatal, the numbers of a plain objrec-detect run, exit codes, and a clean Ctrl-C."""

from __future__ import annotations

import csv
import json
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import pytest

from objrec_apps import detect
from objrec_apps.batch_worker import SourceResult, count_kept_lines, output_names
from objrec_core import open_source

BATCH = [sys.executable, "-m", "objrec_apps.batch"]
FRAMES = 6


def run(args: list[str], cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*BATCH, *args], capture_output=True, text=True, cwd=cwd, timeout=timeout)


def demo_frames(seed: int, frames: int = FRAMES) -> list:
    with open_source(f"demo:seed={seed},frames={frames}", "2d") as source:
        return [frame.data for frame in source]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Seven good recordings of the 2D demo scene (four MJPG videos, three PNG folders, one folder named like
    a video, so that two outputs would be clip1) and one corrupt video."""
    root = tmp_path_factory.mktemp("recordings")
    (root / "videos").mkdir()
    (root / "folders").mkdir()
    made: dict[str, Path] = {}
    for seed in range(1, 5):
        path = root / "videos" / f"clip{seed}.avi"
        images = demo_frames(seed)
        height, width = images[0].shape[:2]
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (width, height))
        for image in images:
            writer.write(image)
        writer.release()
        made[f"clip{seed}.avi"] = path
    for seed, name in ((5, "clip1"), (6, "clip6"), (7, "clip7")):
        folder = root / "folders" / name
        folder.mkdir()
        for index, image in enumerate(demo_frames(seed)):
            assert cv2.imwrite(str(folder / f"frame{index}.png"), image)
        made[f"folder {name}"] = folder
    broken = root / "videos" / "broken.avi"
    broken.write_bytes(b"RIFF\x00\x10\x00\x00AVI LIST" + bytes(range(256)) * 40)  # a header, then garbage
    made["broken.avi"] = broken
    return made


def read_summary(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as stream:
        return list(csv.DictReader(stream))


def detections(path: Path) -> list[list[dict]]:
    """Each frame's objects (names and polygons) from a JSON Lines output; stamps differ between runs."""
    return [json.loads(line)["objects"] for line in path.read_text().splitlines()]


def test_eight_recordings_on_two_workers(project_root: Path, recordings: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "out"
    sources = [str(p) for p in recordings.values()]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    result = run(["params/hsv_demo.yaml", *sources, "--out", str(out), "--workers", "2", "--progress"], project_root)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_seconds = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime  # the command and its workers
    assert result.returncode == 1, result.stderr  # one source failed
    assert "Traceback" not in result.stderr
    assert cpu_seconds < 40, cpu_seconds  # CPU seconds of the command and its workers, not wall-clock

    expected_names = ["clip1.jsonl", "clip2.jsonl", "clip3.jsonl", "clip4.jsonl", "clip1-2.jsonl", "clip6.jsonl",
                      "clip7.jsonl", "broken.jsonl"]
    assert sorted(p.name for p in out.iterdir()) == sorted([*expected_names, "summary.csv"])
    rows = read_summary(out / "summary.csv")
    assert [r["source"] for r in rows] == sources
    assert [r["output"] for r in rows] == expected_names
    assert list(rows[0]) == ["source", "output", "frames", "frames_with_objects", "objects", "frames_per_s",
                             "seconds", "status", "runs"]

    broken = rows[-1]
    assert broken["status"] == f"failed: {recordings['broken.avi']}: cannot open video file"
    assert (broken["frames"], broken["objects"]) == ("0", "0")
    assert (out / "broken.jsonl").read_text() == ""
    assert f"{recordings['broken.avi']}: cannot open video file" in result.stderr  # said as it happened too

    for row, source in zip(rows[:-1], sources[:-1], strict=True):
        assert row["status"] == "ok", row
        output = out / row["output"]
        assert int(row["frames"]) == FRAMES == len(output.read_text().splitlines())
        assert float(row["frames_per_s"]) > 0
        # the same source through a plain objrec-detect run: the same numbers and the same objects
        reference = tmp_path / f"reference-{row['output']}"
        assert detect.main([str(project_root / "params" / "hsv_demo.yaml"), "--source", source,
                            "--output", str(reference)]) == 0
        expected = detections(reference)
        assert detections(output) == expected
        assert int(row["objects"]) == sum(len(objects) for objects in expected) > 0
        assert int(row["frames_with_objects"]) == sum(bool(objects) for objects in expected)

    # the table on stdout: a heading and one row per source, in the order given
    table = result.stdout.splitlines()
    assert table[0].split() == ["source", "output", "frames", "with", "objects", "objects", "frames/s", "status"]
    assert [line.split()[0] for line in table[1:]] == sources
    assert table[-1].split()[2:6] == ["0", "0", "0", "0.0"] and "failed: " in table[-1]
    assert "8/8" in result.stderr  # the progress bar over sources
    assert "objrec-batch: 8 sources, 1 failed; 42 frames" in result.stderr


def test_all_good_sources_exit_0_and_mcap_reads_back(project_root: Path, recordings: dict[str, Path],
                                                     tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    from rosbags.highlevel import AnyReader

    sources = [str(recordings["clip2.avi"]), str(recordings["folder clip6"])]
    out = tmp_path / "typed"
    result = run(["params/hsv_demo.yaml", *sources, "-o", str(out), "-w", "2", "--format", "mcap",
                  "--max-frames", "4"], project_root)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    rows = read_summary(out / "summary.csv")
    assert [(r["output"], r["frames"], r["status"]) for r in rows] == [("clip2.mcap", "4", "ok"),
                                                                       ("clip6.mcap", "4", "ok")]
    for row, source in zip(rows, sources, strict=True):
        reference = tmp_path / f"{row['output']}.jsonl"
        assert detect.main([str(project_root / "params" / "hsv_demo.yaml"), "--source", source, "-n", "4",
                            "-o", str(reference)]) == 0
        expected = detections(reference)
        with AnyReader([out / row["output"]]) as reader:
            [connection] = reader.connections
            assert connection.topic == "/objrec/coloured_object"
            assert connection.msgtype == "object_detection_2d_msgs/msg/DetectedObject2DArray"
            messages = [reader.deserialize(raw, connection.msgtype) for _, _, raw in reader.messages()]
        assert [len(m.objects) for m in messages] == [len(objects) for objects in expected]
        assert int(row["objects"]) == sum(len(m.objects) for m in messages) > 0
        first = messages[0].objects[0]
        assert first.name == expected[0][0]["name"]
        assert [(p.x, p.y) for p in first.polygon.points] == [(p["x"], p["y"]) for p in
                                                              expected[0][0]["polygon"]["points"]]


def test_existing_scheduler_runs_the_sources(project_root: Path, recordings: dict[str, Path], tmp_path: Path) -> None:
    from distributed import LocalCluster

    # threads in this process are enough for a scheduler the command has to find by its address
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://", host="127.0.0.1",
                      dashboard_address=None, scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster:
        out = tmp_path / "remote"
        result = run(["params/hsv_demo.yaml", str(recordings["clip3.avi"]), "demo:seed=3,frames=2", "--out", str(out),
                      "--scheduler", cluster.scheduler_address, "--workers", "4"], project_root)
    assert result.returncode == 0, result.stderr
    assert "--workers is ignored with --scheduler" in result.stderr
    assert " s on 1 worker after the cluster started" in result.stderr
    rows = read_summary(out / "summary.csv")
    assert [(r["output"], r["frames"], r["objects"], r["status"]) for r in rows] == [
        ("clip3.jsonl", "6", str(4 * 6), "ok"),
        ("demo_seed_3_frames_2.jsonl", "2", str(4 * 2), "ok"),
    ]


def write_image_bag(path: Path, seed: int, frames: int = FRAMES) -> None:
    """The 2D demo scene as sensor_msgs/Image (bgr8): a ROS 1 bag for ``.bag``, else a ROS 2 bag folder (MCAP)."""
    import numpy as np
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = path.suffix == ".bag"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    msgtype = "sensor_msgs/msg/Image"
    writer = Writer1(path) if ros1 else Writer2(path, version=8, storage_plugin=StoragePlugin.MCAP)
    with writer:
        connection = writer.add_connection("/camera/image", msgtype, typestore=store)
        for index, image in enumerate(demo_frames(seed, frames)):
            stamp = store.types["builtin_interfaces/msg/Time"](sec=1_700_000_000 + index, nanosec=0)
            header = store.types["std_msgs/msg/Header"](**({"seq": index} if ros1 else {}), stamp=stamp,
                                                        frame_id="cam")
            height, width = image.shape[:2]
            message = store.types[msgtype](header=header, height=height, width=width, encoding="bgr8",
                                           is_bigendian=0, step=width * 3, data=np.ascontiguousarray(image).ravel())
            writer.write(connection, (1_700_000_000 + index) * 10**9, serialize(message, msgtype))


def test_bags_in_a_batch(project_root: Path, tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    ros1, ros2, truncated = tmp_path / "drive.bag", tmp_path / "drive", tmp_path / "cut.bag"
    write_image_bag(ros1, seed=11)
    write_image_bag(ros2, seed=12)
    truncated.write_bytes(ros1.read_bytes()[:4000])
    out = tmp_path / "out"
    sources = [str(ros1), str(ros2), str(truncated)]
    result = run(["params/hsv_demo.yaml", *sources, "--out", str(out), "-w", "2"], project_root)
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr
    rows = read_summary(out / "summary.csv")
    assert [r["output"] for r in rows] == ["drive.jsonl", "drive-2.jsonl", "cut.jsonl"]
    assert rows[2]["status"].startswith(f"failed: {truncated}: ") and rows[2]["frames"] == "0"
    for row, source in zip(rows[:2], sources[:2], strict=True):
        assert row["status"] == "ok"
        reference = tmp_path / f"reference-{row['output']}"
        assert detect.main([str(project_root / "params" / "hsv_demo.yaml"), "--source", source,
                            "--output", str(reference)]) == 0
        lines = [json.loads(line) for line in (out / row["output"]).read_text().splitlines()]
        assert [line["objects"] for line in lines] == detections(reference)
        assert int(row["objects"]) == sum(len(line["objects"]) for line in lines) > 0
        # the frames keep the messages' stamps and frame_id
        assert [(line["header"]["stamp"]["secs"], line["header"]["frame_id"]) for line in lines] == [
            (1_700_000_000 + i, "cam") for i in range(FRAMES)]


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["missing.yaml", "demo:frames=1"], "missing.yaml: file not found"),
        (["params/hsv_demo.yaml"], "the following arguments are required: SOURCE"),
        (["params/hsv_demo.yaml", "demo:frames=1", "-w", "0"], "--workers: 0 is below the minimum 1"),
        (["params/hsv_demo.yaml", "demo:frames=1", "-n", "x"], "--max-frames: 'x' is not a whole number"),
        (["params/hsv_demo.yaml", "demo:frames=1", "--format", "csv"], "--format: invalid choice"),
        (["params/hsv_demo.yaml", "demo:frames=1", "--scheduler", "nonsense://x"], "unknown address scheme"),
        (["params/hsv_demo.yaml", "demo:frames=1", "--output-topic", "/a"], "--output-topic is for --format mcap"),
        (["params/hsv_demo.yaml", "demo:frames=1,frames=2"], "option frames is given twice"),
    ],
)
def test_user_mistakes_give_one_line_and_exit_2(project_root: Path, tmp_path: Path, args: list[str],
                                                fragment: str) -> None:
    result = run([*args, "--out", str(tmp_path / "out")], project_root)
    assert result.returncode == 2, result.stderr
    assert fragment in result.stderr
    assert result.stderr.startswith("objrec-batch: error: ")
    assert len(result.stderr.strip().splitlines()) == 1
    assert result.stdout == ""


def test_bad_parameter_file_and_unwritable_out_dir(project_root: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text((project_root / "params" / "hsv_demo.yaml").read_text().replace("iterations: 1", "iterations: x"))
    result = run([str(bad), "demo:frames=1", "--out", str(tmp_path / "out")], project_root)
    assert result.returncode == 2
    assert result.stderr.startswith(f"objrec-batch: error: {bad}:21: pipeline[1].parameters.iterations: 'x' is "
                                    "invalid: expected an integer")
    assert len(result.stderr.splitlines()) == 1
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    for out, message in ((blocker, "exists and is not a folder"), (blocker / "sub", "output folder cannot be written")):
        result = run(["params/hsv_demo.yaml", "demo:frames=1", "--out", str(out)], project_root)
        assert result.returncode == 2
        assert result.stderr == f"objrec-batch: error: {out}: {message}" + (
            ": Not a directory\n" if out != blocker else "\n")


def test_ctrl_c_stops_running_sources_and_writes_the_summary(project_root: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    long_runs = [f"demo:seed={seed},frames=100000" for seed in (1, 2, 3)]
    process = subprocess.Popen([*BATCH, "params/hsv_demo.yaml", *long_runs, "--out", str(out), "-w", "2"],
                               cwd=project_root, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        deadline = time.monotonic() + 180  # a hang guard, never a speed bound
        outputs = [out / f"demo_seed_{seed}_frames_100000.jsonl" for seed in (1, 2)]
        while not all(p.exists() and p.stat().st_size > 0 for p in outputs):  # both workers are at it
            assert time.monotonic() < deadline and process.poll() is None
            time.sleep(0.2)
        os.killpg(process.pid, signal.SIGINT)  # as a terminal does: the whole process group
        stdout, stderr = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr
    assert "interrupted: stopping the running sources" in stderr
    rows = read_summary(out / "summary.csv")
    assert [r["status"] for r in rows] == ["stopped", "stopped", "cancelled"]
    for row in rows[:2]:
        lines = (out / row["output"]).read_text().splitlines()
        assert int(row["frames"]) == len(lines) > 0  # the output ends with whole lines, as many as counted
        assert json.loads(lines[-1])["objects"]
    assert not (out / rows[2]["output"]).exists()
    assert len(stdout.splitlines()) == 4


def test_output_names_are_unique_and_safe() -> None:
    names = output_names(["a/clip.avi", "b/clip.avi", "CLIP.mp4", "c/clip-2.avi", "demo:seed=3,frames=4",
                          "frames/", "summary.csv"], ".jsonl")
    assert names == ["clip.jsonl", "clip-2.jsonl", "CLIP-3.jsonl", "clip-2-2.jsonl", "demo_seed_3_frames_4.jsonl",
                     "frames.jsonl", "summary.jsonl"]


def test_a_crashed_sources_counts_are_what_its_kept_lines_hold(tmp_path: Path) -> None:
    """A source whose worker process died: its row counts the whole detection lines its file kept; a line the
    death cut short, or a line that is no detection, is not a frame."""
    kept = tmp_path / "clip.jsonl"
    lines = [{"header": {"seq": 0}, "objects": [{"name": "a"}, {"name": "b"}]}, {"header": {"seq": 1}, "objects": []},
             {"header": {"seq": 2}, "objects": [{"name": "a"}]}]
    kept.write_text("".join(json.dumps(line) + "\n" for line in lines) + "not json\n" + '{"header": {"seq": 3}, "obj',
                    encoding="utf-8")
    result = SourceResult("clip.bag", kept.name, status="failed: its worker process died running it, twice")
    count_kept_lines(result, kept)
    assert (result.frames, result.frames_with_objects, result.objects) == (3, 2, 3)
    count_kept_lines(result, tmp_path / "gone.jsonl")  # nothing to read: the counts stay as they were
    assert result.frames == 3


def test_a_crashed_sources_row_says_what_became_of_its_output(project_root: Path, tmp_path: Path) -> None:
    """A source whose worker died while running it: JSON Lines keep the lines written before, a typed output
    (written whole or not at all) is not there, and the row says which."""
    from objrec_apps.batch import _killed_status, make_plan

    for fmt in ("jsonl", "mcap"):
        plan = make_plan(str(project_root / "params/hsv_demo.yaml"), ["demo:frames=2"], str(tmp_path / fmt), fmt)
        output = plan.out_dir / plan.outputs[0]
        if fmt == "jsonl":
            output.parent.mkdir(parents=True, exist_ok=True)
            output.write_text('{"objects": []}\n', encoding="utf-8")
        said = {"jsonl": f"; {output.name} keeps the frames done before",
                "mcap": f"; no {output.name}: a typed output is written whole or not at all"}[fmt]
        status = _killed_status(output, plan, 2, 2)
        assert status.startswith("failed: its worker process died running it, twice"), status
        assert status.endswith(said), status
        assert output.exists() == (fmt == "jsonl")  # nothing made up in place of the lost MCAP


def test_a_never_started_source_gets_an_empty_output_in_either_format(project_root: Path, tmp_path: Path) -> None:
    """Worker processes died running other sources before this one started: it still has its output, an empty
    JSON Lines file or an MCAP file (read back by the mcap library) with its channel and no message."""
    from mcap.reader import make_reader

    from objrec_apps.batch import _killed_status, make_plan

    for fmt in ("jsonl", "mcap"):
        plan = make_plan(str(project_root / "params/hsv_demo.yaml"), ["demo:frames=2"], str(tmp_path / fmt), fmt)
        output = plan.out_dir / plan.outputs[0]
        status = _killed_status(output, plan, 0, 2)
        assert status.startswith("failed: never started: the worker processes given it died twice"), status
        if fmt == "jsonl":
            assert output.read_bytes() == b""
            continue
        with open(output, "rb") as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == 0
        assert [c.topic for c in summary.channels.values()] == [plan.topic]
