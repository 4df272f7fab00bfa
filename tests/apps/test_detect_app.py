"""objrec-detect end to end: JSON shape, exit codes, outputs, annotations and clean stops."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import cv2
import pytest

DETECT = [sys.executable, "-m", "objrec_apps.detect"]


def run(args, cwd, timeout=120):
    return subprocess.run([*DETECT, *args], capture_output=True, text=True, cwd=cwd, timeout=timeout)


def test_demo_prints_one_json_line_per_frame(project_root):
    result = run(
        ["params/hsv_demo.yaml", "--source", "demo", "--max-frames", "5", "--frame-id", "head_cam"], project_root
    )
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(lines) == 5
    assert [line["header"]["seq"] for line in lines] == [0, 1, 2, 3, 4]
    for line in lines:
        assert set(line) == {"header", "objects"}
        assert set(line["header"]) == {"seq", "stamp", "frame_id"} and line["header"]["frame_id"] == "head_cam"
        assert set(line["header"]["stamp"]) == {"secs", "nsecs"}
        assert len(line["objects"]) == 4
        for obj in line["objects"]:
            assert set(obj) == {"name", "polygon"} and obj["name"] == "coloured_object"
            assert all(set(p) == {"x", "y", "z"} and p["z"] == 0 for p in obj["polygon"]["points"])
    assert "5 frames, 20 objects" in result.stderr and "frames/s" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["missing.yaml", "--source", "demo"], "missing.yaml: file not found"),
        (["params/hsv_demo.yaml", "--source", "nowhere.mp4"], "nowhere.mp4: no such file"),
        (["params/hsv_demo.yaml", "--source", "camera:abc"], "camera:abc: option index='abc' is invalid: expected int"),
        (["params/hsv_demo.yaml", "--source", "demo:frames=-2"], "option frames='-2' is invalid: out of range"),
        (["params/shape_demo.yaml", "--source", "camera:0"], "camera:0: a source of 2d data, but"),
        (["params/hsv_demo.yaml", "--source", "demo", "--max-frames", "0"], "--max-frames: 0 is below the minimum 1"),
    ],
)
def test_user_mistakes_give_one_line_and_exit_2(project_root, args, fragment):
    result = run(args, project_root)
    assert result.returncode == 2
    assert fragment in result.stderr
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert result.stdout == ""


def test_bad_parameter_file_names_file_and_key(project_root, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text((project_root / "params" / "hsv_demo.yaml").read_text().replace("iterations: 1", "iterations: many"))
    result = run([str(bad), "--source", "demo"], project_root)
    assert result.returncode == 2
    assert f"{bad}:21: pipeline[1].parameters.iterations: 'many' is invalid: expected an integer" in result.stderr
    assert "Traceback" not in result.stderr


def test_output_file_and_annotated_png_folder(project_root, tmp_path):
    out, pictures = tmp_path / "objects.jsonl", tmp_path / "pictures"
    result = run(
        ["params/hsv_demo.yaml", "-s", "demo", "-n", "4", "-o", str(out), "--annotate", str(pictures)], project_root
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""
    assert len(out.read_text().splitlines()) == 4
    files = sorted(pictures.glob("*.png"))
    assert [f.name for f in files] == [f"frame_{i:06d}.png" for i in range(4)]
    image = cv2.imread(str(files[0]))
    assert image.shape == (480, 640, 3)
    # the polygons are drawn: the annotated picture differs from the raw demo frame around the objects
    from objrec2d import DemoSource

    raw = next(iter(DemoSource(frames=1))).data
    assert (cv2.absdiff(image, raw).max(axis=2) > 60).sum() > 500


def test_annotated_video_is_readable(project_root, tmp_path):
    video = tmp_path / "objects.avi"
    result = run(["params/hsv_demo.yaml", "-s", "demo", "-n", "6", "--annotate", str(video)], project_root)
    assert result.returncode == 0, result.stderr
    capture = cv2.VideoCapture(str(video))
    frames = 0
    while capture.read()[0]:
        frames += 1
    assert frames == 6


def test_image_folder_source_shows_progress_when_asked(project_root, tmp_path):
    from objrec2d import DemoSource

    folder = tmp_path / "frames"
    folder.mkdir()
    for frame in DemoSource(frames=3):
        cv2.imwrite(str(folder / f"{frame.index}.png"), frame.data)
    result = run(["params/hsv_demo.yaml", "-s", str(folder), "--progress"], project_root)
    assert result.returncode == 0, result.stderr
    assert len(result.stdout.splitlines()) == 3
    assert "3/3" in result.stderr


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_stops_cleanly_with_everything_flushed(project_root, sig):
    process = subprocess.Popen(
        [*DETECT, "params/hsv_demo.yaml", "--source", "demo"],
        cwd=project_root,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    first = process.stdout.readline()  # running: at least one frame is out
    time.sleep(0.5)
    os.kill(process.pid, sig)
    rest, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    lines = [first, *rest.splitlines()]
    assert len(lines) >= 2
    for line in lines:
        json.loads(line)  # every line complete
    assert "Traceback" not in err
    assert f"{len(lines)} frames" in err


def test_a_picture_as_annotation_target_is_refused(project_root, tmp_path):
    result = run(
        ["params/hsv_demo.yaml", "-s", "demo", "-n", "1", "--annotate", str(tmp_path / "one.png")], project_root
    )
    assert result.returncode == 2
    assert "give a folder" in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "one.png").exists()


def test_a_full_disk_is_one_error_line(project_root):
    result = run(["params/hsv_demo.yaml", "-s", "demo", "-n", "3", "-o", "/dev/full"], project_root)
    assert result.returncode == 2  # a write failure is an error of what was asked for, like any other output
    assert "No space left on device" in result.stderr and "Traceback" not in result.stderr


def test_a_source_that_yields_no_frame_is_a_user_mistake(project_root, tmp_path):
    broken = tmp_path / "scan.pcd"
    broken.write_text(
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
        "WIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary\n\x00\x01"
    )
    result = run(["params/shape_demo.yaml", "-s", str(broken)], project_root)
    assert result.returncode == 2, result.stderr
    assert "scan.pcd" in result.stderr and "Traceback" not in result.stderr
    result = run(["params/hsv_demo.yaml", "-s", str(broken)], project_root)
    assert result.returncode == 2 and "a source of 3d data, but this pipeline works on 2d data" in result.stderr


def test_missing_parent_folders_of_outputs_are_made(project_root, tmp_path):
    video, lines = tmp_path / "out" / "deeper" / "colour.avi", tmp_path / "jsonl" / "objects.jsonl"
    result = run(["params/hsv_demo.yaml", "-s", "demo:frames=3", "--annotate", str(video), "-o", str(lines)],
                 project_root)
    assert result.returncode == 0, result.stderr
    assert video.stat().st_size > 0 and len(lines.read_text().splitlines()) == 3


def test_the_3d_demo_takes_the_same_spec_as_the_2d_one(project_root):
    result = run(["params/shape_demo.yaml", "-s", "demo:seed=2,frames=2"], project_root, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(lines) == 2 and all(line["objects"] for line in lines)
