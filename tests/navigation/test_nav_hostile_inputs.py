"""Hostile maps and pose files through the real ``objrec-patrol``: special files, YAML bombs, absurd numbers and
images whose header claims too much are each refused with exit code 2 and one stderr line naming the file (and
the field), no traceback, in seconds and little memory."""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from navigation.maps import MapError, load_map
from navigation.poses import PoseFileError, load_poses
from tests.hostile import harness

PROJECT = Path(__file__).resolve().parents[2]
LAB = PROJECT / "examples" / "inspection_lab"
CPU_SECONDS_LIMIT = harness.CPU_SECONDS_LIMIT  # CPU seconds of the command
MEMORY_LIMIT_MB = harness.MEMORY_LIMIT_MB
MAP_FIELDS = "resolution: 0.05\norigin: [0.0, 0.0, 0.0]\n"


def patrol(poses: str | Path, map_yaml: str | Path, cwd: Path, env: dict[str, str] | None = None
           ) -> harness.Outcome:
    """One ``objrec-patrol`` run in a child, measured by tests/hostile/harness.py (exit code, stderr lines, CPU
    time, its own peak memory)."""
    return harness.run(["objrec-patrol", poses, "--map", map_yaml, "--laps", "1"], cwd, env=harness.child_env(env))


def png_bomb(width: int, height: int) -> bytes:
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 4096)) + \
        chunk(b"IEND", b"")


def billion_laughs() -> str:
    lines = ["a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"{chr(98 + i)}: &{chr(98 + i)} [" + ", ".join([f"*{chr(97 + i)}"] * 9) + "]" for i in range(8)]
    return "\n".join(lines) + "\n"


def special(tmp: Path, kind: str, name: str) -> str:
    """A FIFO or a folder named ``name`` in ``tmp``, or a device; its path as the command is given it."""
    if kind == "fifo":
        os.mkfifo(tmp / name)
        return name
    if kind == "folder":
        (tmp / name).mkdir()
        return name
    if not os.path.exists(kind):
        pytest.skip(f"{kind} is absent")
    return kind


SPECIALS = [("fifo", "is a FIFO (named pipe), not a regular file"), ("folder", "is a folder"),
            ("/dev/zero", "is a character device"), ("/dev/urandom", "is a character device")]


def _lab_map(tmp: Path, image: str = "lab.pgm") -> Path:
    if image == "lab.pgm":
        (tmp / "lab.pgm").write_bytes((LAB / "lab.pgm").read_bytes())
    path = tmp / "map.yaml"
    path.write_text(f"image: {image}\n" + MAP_FIELDS)
    return path


def refused(run: harness.Outcome, *fragments: str) -> None:
    code, stderr, seconds, rss = run.exit_code, run.stderr, run.cpu_seconds, run.max_rss_mb
    assert code == 2, stderr
    assert "Traceback" not in stderr, stderr
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert seconds < CPU_SECONDS_LIMIT and rss < MEMORY_LIMIT_MB, (seconds, rss)


@pytest.mark.parametrize("kind, why", SPECIALS)
def test_special_files_as_map_yaml(tmp_path, kind, why):
    name = special(tmp_path, kind, "map.yaml")
    refused(patrol(LAB / "lab_poses.txt", name, tmp_path), f"{name}: {why}")


@pytest.mark.parametrize("kind, why", SPECIALS[:3])
def test_special_files_as_map_image(tmp_path, kind, why):
    name = special(tmp_path, kind, "map.pgm")
    _lab_map(tmp_path, name)
    refused(patrol(LAB / "lab_poses.txt", "map.yaml", tmp_path), "map.yaml:1: image: ", f"{name}: {why}")


@pytest.mark.parametrize("kind, why", SPECIALS)
def test_special_files_as_pose_file(tmp_path, kind, why):
    name = special(tmp_path, kind, "poses.txt")
    refused(patrol(name, LAB / "lab.yaml", tmp_path), f"{name}: {why}")


def _map_yaml(text: str) -> Callable[[Path], str]:
    def write(tmp: Path) -> str:
        (tmp / "lab.pgm").write_bytes((LAB / "lab.pgm").read_bytes())
        (tmp / "map.yaml").write_text(text)
        return "map.yaml"

    return write


@pytest.mark.parametrize(
    "make, fragments",
    [
        (_map_yaml("image: lab.pgm\n" + MAP_FIELDS + billion_laughs()),
         ("map.yaml: line 5, column 8: not valid YAML: aliases (*name) are not allowed",)),
        (_map_yaml("image: lab.pgm\n" + MAP_FIELDS + "deep: " + "[" * 200 + "]" * 200 + "\n"),
         ("map.yaml: line 4, column", "nested deeper than 8 levels")),
        (_map_yaml("image: lab.pgm\nresolution: " + "7" * 5000 + "\norigin: [0, 0, 0]\n"),
         ("map.yaml:2: resolution: an integer of 5,000 digits is not a usable number",)),
        (_map_yaml("image: lab.pgm\nresolution: 0.05\norigin: [0, " + "7" * 400 + ", 0]\n"),
         ("map.yaml:3: origin[1]: 77777", "7777 is invalid: expected a finite number")),
        (_map_yaml("image: lab.pgm\nresolution: .nan\norigin: [0, 0, 0]\n"),
         ("map.yaml:2: resolution: nan is invalid: expected a finite number",)),
        (_map_yaml("image: lab.pgm\nresolution: 0.05\norigin: [0, .inf, 0]\n"),
         ("map.yaml:3: origin[1]: inf is invalid: expected a finite number",)),
        (_map_yaml("image: lab.pgm\nresolution: 0.05\norigin: [1.0e+308, 0, 0]\n"),
         ("map.yaml:3: origin[0]: 1e+308 is invalid: out of range, allowed float in -1000000..1000000",)),
        (_map_yaml("image: lab.pgm\nresolution: 1.0e+4\norigin: [0, 0, 0]\n"),
         ("map.yaml:2: resolution: 10000.0 is invalid: out of range, allowed float in (0..1000]",)),
        (_map_yaml("image: lab.pgm\nresolution: 0.05\norigin: [0, 0, -1.0e+9]\n"),
         ("map.yaml:3: origin[2]: -1000000000.0 is invalid: out of range, allowed float in -100..100",)),
    ],
    ids=["billion-laughs", "deep-nesting", "5000-digits", "400-digits", "nan", "inf", "1e308", "resolution",
         "yaw"],
)
def test_hostile_map_yaml_is_refused_naming_the_field(tmp_path, make, fragments):
    refused(patrol(LAB / "lab_poses.txt", make(tmp_path), tmp_path), *fragments)


def test_a_map_png_claiming_30000x30000_cells_is_refused_from_its_header(tmp_path):
    (tmp_path / "bomb.png").write_bytes(png_bomb(30000, 30000))
    _lab_map(tmp_path, "bomb.png")
    refused(patrol(LAB / "lab_poses.txt", "map.yaml", tmp_path), "map.yaml:1: image: ",
            "bomb.png: map of 30000x30000 cells: 900,000,000 cells, over the limit of 4,000,000 cells "
            "(set OBJREC_MAX_MAP_CELLS to raise it)")


def test_a_map_pgm_over_the_cell_limit_and_then_the_pixel_limit(tmp_path):
    (tmp_path / "big.pgm").write_bytes(b"P5\n# a few bytes that claim a lot\n6000 6000\n255\n" + b"\xfe" * 64)
    _lab_map(tmp_path, "big.pgm")
    refused(patrol(LAB / "lab_poses.txt", "map.yaml", tmp_path),
            "big.pgm: map of 6000x6000 cells: 36,000,000 cells, over the limit of 4,000,000 cells")
    # With the cell limit raised for a real huge map, the pixel limit still stands before decoding.
    (tmp_path / "big.pgm").write_bytes(b"P5\n30000 30000\n255\n" + b"\xfe" * 64)
    run = patrol(LAB / "lab_poses.txt", "map.yaml", tmp_path, env={"OBJREC_MAX_MAP_CELLS": "10_000_000_000"})
    refused(run, "big.pgm: image of 30000x30000: 900,000,000 pixels, over the limit of 100,000,000 pixels "
                 "(set OBJREC_MAX_IMAGE_PIXELS to raise it)")


def test_a_truncated_map_png_is_refused_as_truncated(tmp_path):
    data = cv2.imencode(".png", np.random.default_rng(3).integers(0, 255, (200, 200), dtype=np.uint8))[1].tobytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    _lab_map(tmp_path, "cut.png")
    refused(patrol(LAB / "lab_poses.txt", "map.yaml", tmp_path),
            "map.yaml:1: image: ", "cut.png: truncated: the PNG ends before its IEND chunk")


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("station_pose:\n1e308, 2.0, 0, 0, 0, 0, 1\n",
         "poses.txt:2: goals[0].x: '1e308' is invalid: out of range, allowed float in -1000000..1000000"),
        ("2.0, 2.0, 0, 0, 0, 0, 1\n2.0, inf, 0, 0, 0, 0, 1\n",
         "poses.txt:2: goals[1].y: 'inf' is invalid: expected a finite number"),
        ("2.0, " + "9" * 5000 + ", 0, 0, 0, 0, 1\n", "poses.txt:1: goals[0].y: '999999999"),
        ("2.0, 2.0, 0, 0, 0, 1e300, 1\n",
         "poses.txt:1: goals[0].qz: '1e300' is invalid: out of range, allowed float in -1000000..1000000"),
    ],
    ids=["1e308", "inf", "5000-digits", "quaternion"],
)
def test_absurd_pose_numbers_are_refused_naming_line_and_field(tmp_path, text, fragment):
    (tmp_path / "poses.txt").write_text(text)
    refused(patrol("poses.txt", LAB / "lab.yaml", tmp_path), fragment)


def test_more_poses_than_the_limit_are_refused_before_parsing(tmp_path):
    (tmp_path / "poses.txt").write_text("# six goals\n" + "2.0, 2.0, 0, 0, 0, 0, 1\n" * 6)
    run = patrol("poses.txt", LAB / "lab.yaml", tmp_path, env={"OBJREC_MAX_POSES": "5"})
    refused(run, "poses.txt: goal poses: 6 poses, over the limit of 5 poses (set OBJREC_MAX_POSES to raise it)")


def test_the_limits_hold_in_process_too(tmp_path, monkeypatch):
    """The loaders themselves (the GUI and inspection use them without the command)."""
    monkeypatch.delenv("OBJREC_MAX_MAP_CELLS", raising=False)
    (tmp_path / "bomb.png").write_bytes(png_bomb(30000, 30000))
    with pytest.raises(MapError, match=r"OBJREC_MAX_MAP_CELLS"):
        load_map(_lab_map(tmp_path, "bomb.png"))
    monkeypatch.setenv("OBJREC_MAX_POSES", "1")
    (tmp_path / "poses.txt").write_text("1, 1, 0, 0, 0, 0, 1\n2, 2, 0, 0, 0, 0, 1\n")
    with pytest.raises(PoseFileError, match=r"2 poses, over the limit of 1 poses \(set OBJREC_MAX_POSES"):
        load_poses(tmp_path / "poses.txt")
    monkeypatch.delenv("OBJREC_MAX_POSES")
    assert len(load_poses(LAB / "lab_poses.txt").goals) == 4
    assert load_map(LAB / "lab.yaml").resolution == pytest.approx(0.05)


@pytest.mark.parametrize(
    "value, fragment",
    [("7" * 5000, "w.yaml:2: objects[0].x: an integer of 5,000 digits is not a usable number"),
     ("1.0e+308", "w.yaml:2: objects[0].x: 1e+308 is invalid: out of range, allowed float in -1000000..1000000"),
     ("7" * 400, "w.yaml:2: objects[0].x: 7777777777")],
    ids=["5000-digits", "1e308", "400-digits"],
)
def test_a_world_file_refuses_absurd_numbers_naming_the_field(tmp_path, value, fragment):
    from navigation.world import WorldError, parse_world

    text = f"objects:\n  - {{name: p, shape: box, x: {value}, y: 1, width: 1, depth: 1, height: 1}}\n"
    with pytest.raises(WorldError) as caught:
        parse_world(text, tmp_path / "w.yaml")
    assert fragment in str(caught.value) and len(str(caught.value)) < 300
