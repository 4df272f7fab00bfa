"""Outputs of objrec-detect on a full disk, saves onto what must not be replaced, and error lines that stay one line.

A full disk is simulated portably: the command runs in a child with a file size limit (RLIMIT_FSIZE) and
SIGXFSZ ignored, so writes past the limit fail with EFBIG as they would with ENOSPC.
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec2d import BinaryDetector, HSVFilter
from objrec_apps import annotation_writer
from objrec_apps.annotation_writer import AnnotationWriter, readable_frames
from objrec_core import ParameterStorage, RecognitionSystem
from objrec_core.schema import ParameterFileError, validate_document
from objrec_core.storage import ParameterSaveError
from strictio import OutputError
from tests.hostile import harness
from tests.hostile.harness import char_device, the_one_error_line

DETECT = [sys.executable, "-m", "objrec_apps.detect"]


def run_on_full_disk(args: list[str], cwd: Path, limit: int | None) -> tuple[subprocess.CompletedProcess[str], float]:
    """objrec-detect with every file it writes limited to ``limit`` bytes (tests/hostile/harness.py); the result
    and its CPU seconds."""
    run = harness.run([*DETECT, *args, "--no-progress"], cwd, preexec=harness.file_size_limit(limit),
                      watch_files=False)
    return run.completed(), run.cpu_seconds




def no_temporaries(folder: Path) -> bool:
    return not [p for p in folder.rglob("*") if ".saving-" in p.name]


# -- --output: JSON Lines ------------------------------------------------------------------------------------
def test_output_on_a_full_disk_keeps_only_whole_lines(project_root, tmp_path):
    out = tmp_path / "out.jsonl"
    result, cpu_seconds = run_on_full_disk(["params/hsv_demo.yaml", "-s", "demo", "-n", "200", "-o", str(out)],
                                       project_root, limit=5000)
    line = the_one_error_line(result)
    assert re.fullmatch(rf"objrec-detect: error: {re.escape(str(out))}: cannot be written: File too large; "
                        r"\d+ whole lines? before it (is|are) kept", line), line
    text = out.read_text()
    assert 0 < len(text) <= 5000 and text.endswith("\n")
    kept = [json.loads(row) for row in text.splitlines()]  # every line is whole JSON
    assert [row["header"]["seq"] for row in kept] == list(range(len(kept)))
    assert f"{len(kept)} whole line" in line
    assert cpu_seconds < harness.CPU_SECONDS_LIMIT


def test_output_onto_a_full_device_is_one_line_and_the_device_stays(project_root, tmp_path):
    device = char_device(tmp_path)
    result, _ = run_on_full_disk(["params/hsv_demo.yaml", "-s", "demo", "-n", "3", "-o", str(device)],
                                 project_root, limit=None)
    assert "No space left on device" in the_one_error_line(result)
    assert stat.S_ISCHR(device.stat().st_mode)


# -- --annotate: a video or a folder of pictures -----------------------------------------------------------
def test_annotated_avi_on_a_full_disk_stops_early_and_says_how_many_frames_are_readable(project_root, tmp_path):
    video = tmp_path / "out" / "colour.avi"  # the missing folder is made
    result, cpu_seconds = run_on_full_disk(["params/hsv_demo.yaml", "-s", "demo", "-n", "400", "--annotate", str(video),
                                        "-o", os.devnull], project_root, limit=600_000)
    line = the_one_error_line(result)
    found = re.search(r"colour\.avi: cannot be written: the file stopped growing .*; (\d+) of (\d+) frames are "
                      r"readable$", line)
    assert found, line
    readable, written = int(found[1]), int(found[2])
    assert written < 400  # noticed while running, not after every frame went nowhere
    assert 0 < readable < written and readable_frames(video, written) == readable
    assert cpu_seconds < harness.CPU_SECONDS_LIMIT


def test_annotated_mp4_on_a_full_disk_is_checked_at_close(project_root, tmp_path):
    video = tmp_path / "colour.mp4"
    result, _ = run_on_full_disk(["params/hsv_demo.yaml", "-s", "demo", "-n", "40", "--annotate", str(video),
                                  "-o", os.devnull], project_root, limit=200_000)
    line = the_one_error_line(result)
    assert line.endswith("colour.mp4: cannot be written completely (a full disk or a file size limit?): 0 of 40 "
                         "frames are readable"), line


def test_annotated_pictures_on_a_full_disk_leave_no_half_picture(project_root, tmp_path):
    folder = tmp_path / "pictures"
    result, _ = run_on_full_disk(["params/hsv_demo.yaml", "-s", "demo", "-n", "5", "--annotate", str(folder),
                                  "-o", os.devnull], project_root, limit=100_000)  # less than one picture
    line = the_one_error_line(result)
    assert line.endswith("frame_000000.png: cannot be written: File too large; the 0 frames before it are whole")
    assert list(folder.iterdir()) == []


def test_a_picture_that_fails_mid_run_keeps_the_whole_ones(tmp_path, monkeypatch):
    writer = AnnotationWriter(tmp_path / "pictures")
    frame = np.zeros((48, 64, 3), np.uint8)
    writer.write(frame)
    writer.write(frame)
    real_open = open

    def full_disk(path, mode="r", *args, **kwargs):
        stream = real_open(path, mode, *args, **kwargs)
        stream.write(b"\x89PNG half")

        def fail(_data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        stream.write = fail
        return stream

    monkeypatch.setattr(annotation_writer, "open", full_disk, raising=False)
    with pytest.raises(OutputError, match=r"frame_000002\.png: cannot be written: No space left on device; the 2 "
                                          "frames before it are whole"):
        writer.write(frame)
    assert sorted(p.name for p in (tmp_path / "pictures").iterdir()) == ["frame_000000.png", "frame_000001.png"]
    assert all(cv2.imread(str(p)) is not None for p in (tmp_path / "pictures").iterdir())


def test_a_whole_video_passes_the_check_at_close(tmp_path):
    writer = AnnotationWriter(tmp_path / "v.avi")
    for k in range(40):
        writer.write(np.full((48, 64, 3), k * 6, np.uint8))
    writer.close()
    assert readable_frames(tmp_path / "v.avi", 40) == 40


def test_a_video_is_not_written_over_a_device_or_a_read_only_file(tmp_path):
    with pytest.raises(OutputError, match="exists and is not a regular file"):
        AnnotationWriter(char_device(tmp_path).rename(tmp_path / "full.avi"))
    assert stat.S_ISCHR((tmp_path / "full.avi").stat().st_mode)
    locked = tmp_path / "locked.avi"
    locked.write_bytes(b"keep")
    locked.chmod(0o444)
    with pytest.raises(OutputError, match="the file is read-only"):
        AnnotationWriter(locked)
    assert locked.read_bytes() == b"keep"


# -- --explain=PATH: the side file of reasons -----------------------------------------------------------------
def test_explain_side_file_on_a_full_disk_keeps_only_whole_lines(project_root, tmp_path):
    frames = tmp_path / "grey"
    frames.mkdir()
    for k in range(60):  # nothing to find: a reason per frame
        cv2.imwrite(str(frames / f"f{k:03d}.png"), np.full((48, 64, 3), 128, np.uint8))
    reasons = tmp_path / "why.jsonl"
    result, _ = run_on_full_disk(["params/hsv_demo.yaml", "-s", str(frames), f"--explain={reasons}",
                                  "-o", os.devnull], project_root, limit=3000)
    line = the_one_error_line(result)
    assert "why.jsonl" in line and "File too large" in line
    text = reasons.read_text()
    assert text and text.endswith("\n")
    assert all(json.loads(row)["reason"] for row in text.splitlines())


# -- saves of parameter files -------------------------------------------------------------------------------
def system() -> RecognitionSystem:
    return RecognitionSystem([HSVFilter(h_min=5), BinaryDetector()])


def test_saving_parameters_onto_what_must_stay_is_a_save_error(tmp_path):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    locked = tmp_path / "locked.yaml"
    locked.write_text("kept")
    locked.chmod(0o444)
    device = char_device(tmp_path)
    for path, why in ((fifo, "a FIFO"), (device, "a character device"), (tmp_path, "a folder"),
                      (locked, "the file is read-only")):
        with pytest.raises(ParameterSaveError, match=f"cannot save: .*{why}") as caught:
            ParameterStorage(system()).save_parameters(path)
        assert isinstance(caught.value, OutputError) and isinstance(caught.value, ParameterFileError)
    assert stat.S_ISFIFO(fifo.stat().st_mode) and stat.S_ISCHR(device.stat().st_mode)
    assert locked.read_text() == "kept"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo.yaml", "full", "locked.yaml"]


# -- messages: names and values from a file are shown escaped -------------------------------------------------
def test_an_unknown_key_with_a_newline_and_escape_codes_stays_on_one_escaped_line(project_root, tmp_path):
    params = tmp_path / "p.yaml"
    text = (project_root / "params" / "hsv_demo.yaml").read_text()
    params.write_text(text + '"evil\\nobjrec-detect: 10 frames, 0 objects\\e[2J\\e[31m": 1\n')
    with pytest.raises(ParameterFileError) as caught:
        validate_document(params)
    message = str(caught.value)
    assert message.isprintable()
    assert "evil\\nobjrec-detect: 10 frames, 0 objects\\x1b[2J\\x1b[31m: unknown key" in message
    result, _ = run_on_full_disk([str(params), "-s", "demo", "-n", "1"], project_root, limit=None)
    line = the_one_error_line(result)
    assert "evil\\nobjrec-detect" in line and "\x1b" not in result.stderr
