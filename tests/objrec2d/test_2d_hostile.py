"""Hostile image and video sources through the real ``objrec-detect``: each is refused with exit code 2 and one
stderr line naming the file, no traceback, in seconds and little memory; a folder skips what it cannot read
and says so; a truncated video keeps what it made of the frames that decoded and still fails."""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from tests.hostile import harness

PROJECT = Path(__file__).resolve().parents[2]
PARAMS = PROJECT / "params" / "hsv_demo.yaml"
CPU_SECONDS_LIMIT = harness.CPU_SECONDS_LIMIT  # CPU seconds of the command
MEMORY_LIMIT_MB = harness.MEMORY_LIMIT_MB


def detect(source: str | Path, cwd: Path, *extra: str, env: dict[str, str] | None = None) -> harness.Outcome:
    """``objrec-detect PARAMS --source SOURCE -o out.jsonl`` in a child, measured by tests/hostile/harness.py (exit
    code, stderr lines, CPU time, its own peak memory)."""
    return harness.run(["objrec-detect", PARAMS, "--source", source, "-o", "out.jsonl", *extra], cwd,
                       env=harness.child_env(env))


def refused(run: harness.Outcome, name: str, fragment: str) -> None:
    """Exit code 2, exactly one stderr line, naming the file and saying ``fragment``, in bounded time/memory."""
    assert run.exit_code == 2, run
    assert "Traceback" not in run.stderr, run.stderr
    assert len(run.lines) == 1, run.stderr
    assert name in run.lines[0] and fragment in run.lines[0], run.lines[0]
    assert run.cpu_seconds < CPU_SECONDS_LIMIT and run.max_rss_mb < MEMORY_LIMIT_MB, run


def png_bomb(width: int, height: int) -> bytes:
    """A PNG of a few hundred bytes whose header claims ``width`` x ``height`` pixels."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 4096)) + \
        chunk(b"IEND", b"")


def picture(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 255, (120, 160, 3), dtype=np.uint8)


def truncated_jpeg() -> bytes:
    data = cv2.imencode(".jpg", picture(1))[1].tobytes()
    return data[: len(data) // 2]


def write_video(path: Path, frames: int) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for i in range(frames):
        writer.write(np.random.default_rng(i).integers(0, 255, (48, 64, 3), dtype=np.uint8))
    writer.release()


def json_lines(folder: Path) -> int:
    out = folder / "out.jsonl"
    return len(out.read_text().splitlines()) if out.exists() else 0


def test_a_png_claiming_30000x30000_pixels_is_refused_from_its_header(tmp_path):
    (tmp_path / "bomb.png").write_bytes(png_bomb(30000, 30000))
    refused(detect("bomb.png", tmp_path), "bomb.png",
            "image of 30000x30000: 900,000,000 pixels, over the limit of 100,000,000 pixels "
            "(set OBJREC_MAX_IMAGE_PIXELS to raise it)")


def test_an_image_past_opencvs_own_limit_is_one_line_not_a_traceback(tmp_path):
    (tmp_path / "huge.png").write_bytes(png_bomb(40000, 40000))  # 1.6 G pixels: over CV_IO_MAX_IMAGE_PIXELS
    run = detect("huge.png", tmp_path, env={"OBJREC_MAX_IMAGE_PIXELS": "2000000000"})
    refused(run, "huge.png", "OpenCV refuses to decode it")


def test_a_truncated_jpeg_is_refused_as_truncated(tmp_path):
    (tmp_path / "cut.jpg").write_bytes(truncated_jpeg())
    refused(detect("cut.jpg", tmp_path), "cut.jpg", "truncated: the JPEG ends before its end-of-image marker")
    assert json_lines(tmp_path) == 0


@pytest.mark.parametrize("name", ["camera.png", "stream.avi", "stream"])
def test_a_fifo_is_refused_at_once_whatever_its_name(tmp_path, name):
    os.mkfifo(tmp_path / name)
    refused(detect(name, tmp_path), name, "is a FIFO (named pipe), not a regular file")


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_a_device_is_refused_not_read(tmp_path, device):
    if not os.path.exists(device):
        pytest.skip(f"{device} is absent")
    refused(detect(device, tmp_path), device, "is a character device, not a regular file (for a camera, give camera:N)")


def test_a_folder_without_images_is_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    refused(detect("empty", tmp_path), "empty", "folder holds no images")


def test_a_video_whose_frames_are_over_the_pixel_limit_is_refused_before_reading(tmp_path):
    write_video(tmp_path / "clip.avi", 5)
    run = detect("clip.avi", tmp_path, env={"OBJREC_MAX_IMAGE_PIXELS": "1000"})
    refused(run, "clip.avi", "frames of 64x48: 3,072 pixels, over the limit of 1,000 pixels")
    assert json_lines(tmp_path) == 0


def test_a_truncated_video_keeps_its_decoded_frames_and_exits_2(tmp_path):
    write_video(tmp_path / "full.avi", 40)
    data = (tmp_path / "full.avi").read_bytes()
    (tmp_path / "cut.avi").write_bytes(data[: len(data) // 2])
    run = detect("cut.avi", tmp_path)
    assert run.exit_code == 2 and "Traceback" not in run.stderr, run
    errors = [line for line in run.lines if "error:" in line]
    assert len(errors) == 1 and len(run.lines) == 1, run.stderr
    read = json_lines(tmp_path)
    assert 5 < read < 40
    assert f"cut.avi: truncated or corrupt: frame {read} of 40 cannot be decoded; {read} of 40 frames were read" \
        in errors[0]
    assert run.cpu_seconds < CPU_SECONDS_LIMIT and run.max_rss_mb < MEMORY_LIMIT_MB


def test_a_folder_skips_each_bad_file_with_one_warning_and_exits_0(tmp_path):
    folder = tmp_path / "shots"
    folder.mkdir()
    cv2.imwrite(str(folder / "a_good.png"), picture(2))
    cv2.imwrite(str(folder / "e_good.jpg"), picture(3))
    (folder / "b_cut.jpg").write_bytes(truncated_jpeg())
    (folder / "c_bomb.png").write_bytes(png_bomb(30000, 30000))
    (folder / "d_notes.png").write_text("not a picture")
    os.mkfifo(folder / "f_pipe.png")
    run = detect(folder, tmp_path)
    assert run.exit_code == 0 and "Traceback" not in run.stderr, run
    assert json_lines(tmp_path) == 2
    for name, why in (("b_cut.jpg", "truncated"), ("c_bomb.png", "OBJREC_MAX_IMAGE_PIXELS"),
                      ("d_notes.png", "not a readable image"), ("f_pipe.png", "FIFO")):
        said = [line for line in run.lines if name in line]
        assert len(said) == 1 and why in said[0] and "skipped" in said[0], run.stderr
    assert not [line for line in run.lines if "good" in line or "libpng" in line or "JPEG" in line.split(":")[0]]
    assert run.cpu_seconds < CPU_SECONDS_LIMIT and run.max_rss_mb < MEMORY_LIMIT_MB


def test_a_folder_of_nothing_readable_exits_2(tmp_path):
    folder = tmp_path / "broken"
    folder.mkdir()
    (folder / "cut.jpg").write_bytes(truncated_jpeg())
    (folder / "bomb.png").write_bytes(png_bomb(30000, 30000))
    run = detect(folder, tmp_path)
    assert run.exit_code == 2 and "Traceback" not in run.stderr, run
    errors = [line for line in run.lines if "error:" in line]
    assert len(errors) == 1 and "no readable image in the folder: none of its 2 images could be read" in errors[0]
    assert len(run.lines) == 3  # a warning for each file, then the error
    assert run.cpu_seconds < CPU_SECONDS_LIMIT and run.max_rss_mb < MEMORY_LIMIT_MB


def test_an_embedded_target_claiming_20000x20000_pixels_is_refused_before_decoding():
    from objrec2d.features import FeatureConfig, TargetError, target_from_state

    config = FeatureConfig("ORB", (("max_features", 500),))
    rect = {"x": 0, "y": 0, "width": 16, "height": 16}
    state = {"features": config.to_dict(), "rect": rect, "roi": rect, "image": png_bomb(20000, 20000)}
    with pytest.raises(TargetError, match=r"^target\.image: image of 20000x20000: 400,000,000 pixels, over the "
                                          r"limit of 100,000,000 pixels \(set OBJREC_MAX_IMAGE_PIXELS"):
        target_from_state(state, config)
    state["image"] = cv2.imencode(".png", picture(4))[1].tobytes()[:-30]
    with pytest.raises(TargetError, match=r"^target\.image: truncated: the PNG ends before its IEND chunk"):
        target_from_state(state, config)


def test_a_compressed_image_message_claiming_30000x30000_pixels_is_a_decode_error():
    from types import SimpleNamespace

    pytest.importorskip("rosbags")
    from objrec2d.bag_source import decode_compressed
    from objrec_ros.decode import DecodeError

    with pytest.raises(DecodeError, match=r"compressed image \(format 'png'\): image of 30000x30000: "
                                          r"900,000,000 pixels, over the limit"):
        decode_compressed(SimpleNamespace(format="png", data=np.frombuffer(png_bomb(30000, 30000), np.uint8)))
    with pytest.raises(DecodeError, match=r"format 'jpeg'\): truncated: the JPEG ends before"):
        decode_compressed(SimpleNamespace(format="jpeg", data=truncated_jpeg()))
    whole = cv2.imencode(".jpg", picture(5))[1].tobytes()
    assert decode_compressed(SimpleNamespace(format="jpeg", data=whole)).shape == (120, 160, 3)
