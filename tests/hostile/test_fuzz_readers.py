"""Fuzzing the readers of untrusted files in this process: parameter files, map YAMLs and map images, pose files,
PCD headers. Valid shipped files are mutated (characters, YAML tokens, numbers and lines inserted, deleted,
replaced); every call must either succeed or raise the reader's user error (what the commands turn into one line
and exit code 2), and return quickly. Anything else (a KeyError, an OverflowError, a cv2.error, a
RecursionError) is a traceback for the user, and Hypothesis shrinks it to a small file.
"""

from __future__ import annotations

import contextlib
import math
import os
import time
from collections.abc import Callable
from datetime import timedelta
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import navigation
import objrec_apps
from navigation.maps import MapError, load_map
from navigation.poses import PoseFileError, load_poses
from objrec3d.cloud import PointCloud
from objrec3d.pcd import CloudFileError, read_pcd, write_pcd
from objrec_core import ParameterFileError, build_system
from strictio import InputError

T = TypeVar("T")
SYSTEMS = Path(objrec_apps.__file__).parent / "systems"
NAV_DATA = Path(navigation.__file__).parent / "data"
#: Most processor time a single read may take: a pathological input (an alias bomb, a quadratic parse) takes far
#: more, the slowest valid read (the feature system, 200 KB with its target) 0.1 s. Processor time, not wall time,
#: so that other work on a shared machine cannot fail a case; the wall-clock deadline only catches a hang.
READ_CPU_SECONDS = 2.0
# derandomize: the same examples in every CI run (a new random failure would block an unrelated change); run
# with HYPOTHESIS_RANDOM=1 to explore new ones.
FUZZ = settings(max_examples=200, deadline=timedelta(seconds=60), database=None,
                derandomize=os.environ.get("HYPOTHESIS_RANDOM") != "1",
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

#: Pieces that make readers trip: YAML syntax, tags, aliases, odd numbers, control characters, long digits.
TOKENS = [
    "&a ", "*a", "!!python/object/apply:os.system ['true']", "!!binary ", "!!float ", "{", "}", "[", "]", ": ",
    "- ", "? ", "|", ">", "\n", "  ", "\t", "'", '"', "#", ",", "---\n", "...\n", "%YAML 1.1\n", "~", "null",
    "!!int ", "!!bool ", "nan", ".nan", ".inf", "-.inf", "inf", "1e308", "1e999", "-1", "0", "0x7fffffff", "1_000",
    "9" * 40, "9" * 5000, "\x00", "\x1b[2J", "\r", "\u2028", "\ufeff", "é", "true", "2001-12-14", "<<: *a",
]


@st.composite
def mutated(draw: st.DrawFn, text: str, tokens: list[str] = TOKENS) -> str:
    """``text`` with one to four edits: a token or random text inserted, a span deleted, a line duplicated,
    dropped or swapped, a line's value replaced."""
    for _ in range(draw(st.integers(1, 4))):
        lines = text.split("\n")
        edit = draw(st.sampled_from(["insert", "delete", "value", "line", "random"]))
        if edit == "insert":
            at = draw(st.integers(0, len(text)))
            text = text[:at] + draw(st.sampled_from(tokens)) + text[at:]
        elif edit == "delete":
            at = draw(st.integers(0, len(text)))
            text = text[:at] + text[at + draw(st.integers(1, 40)):]
        elif edit == "value":
            row = draw(st.integers(0, len(lines) - 1))
            head = lines[row].split(":", 1)[0] if ":" in lines[row] else lines[row].split(",", 1)[0]
            lines[row] = head + draw(st.sampled_from([": ", ", ", ":", " "])) + draw(st.sampled_from(tokens))
            text = "\n".join(lines)
        elif edit == "line":
            row, other = draw(st.integers(0, len(lines) - 1)), draw(st.integers(0, len(lines) - 1))
            how = draw(st.sampled_from(["duplicate", "drop", "swap"]))
            if how == "duplicate":
                lines.insert(other, lines[row])
            elif how == "drop":
                del lines[row]
            else:
                lines[row], lines[other] = lines[other], lines[row]
            text = "\n".join(lines)
        else:
            at = draw(st.integers(0, len(text)))
            text = text[:at] + draw(st.text(max_size=12)) + text[at:]
    return text


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def quick(read: Callable[[Path], T], path: Path) -> T:
    """``read(path)``, asserting it took little processor time, whatever it ends with."""
    start = time.process_time()
    try:
        return read(path)
    finally:
        spent = time.process_time() - start
        assert spent < READ_CPU_SECONDS, f"{read.__name__}({path.name}) took {spent:.1f} s of processor time"


def write(path: Path, text: str | bytes) -> Path:
    if isinstance(text, str):
        path.write_bytes(text.encode("utf-8", "surrogatepass"))
    else:
        path.write_bytes(text)
    return path


# -- parameter files -----------------------------------------------------------------------------------------

HSV_TEXT = (SYSTEMS / "hsv_demo.yaml").read_text(encoding="utf-8")
SHAPE_TEXT = (SYSTEMS / "shape_demo.yaml").read_text(encoding="utf-8")
FEATURE_TEXT = (SYSTEMS / "feature_demo.yaml").read_text(encoding="utf-8")
FEATURE_HEAD, FEATURE_TARGET = FEATURE_TEXT.split("      image: !!binary |\n", 1)
#: How much of the target's base64 is mutated (the rest is kept, so the picture stays mostly intact).
TARGET_PREFIX = 4000


@FUZZ
@given(text=st.one_of(mutated(HSV_TEXT), mutated(SHAPE_TEXT)))
def test_parameter_files_load_or_say_why(folder: Path, text: str) -> None:
    path = write(folder / "params.yaml", text)
    with contextlib.suppress(ParameterFileError, InputError):
        quick(build_system, path)


@settings(FUZZ, max_examples=100)
@given(head=mutated(FEATURE_HEAD), target=st.one_of(st.none(), mutated(FEATURE_TARGET[:TARGET_PREFIX])))
def test_feature_files_with_their_target_load_or_say_why(folder: Path, head: str, target: str | None) -> None:
    """The feature system, its parameters and the embedded target picture (base64 of a PNG) mutated."""
    picture = FEATURE_TARGET if target is None else target + FEATURE_TARGET[TARGET_PREFIX:]
    path = write(folder / "feature.yaml", head + "      image: !!binary |\n" + picture)
    with contextlib.suppress(ParameterFileError, InputError):
        quick(build_system, path)


# -- maps ----------------------------------------------------------------------------------------------------

MAP_TEXT = (NAV_DATA / "b5203.yaml").read_text(encoding="utf-8").replace(
    "image: b5203.pgm", f"image: {NAV_DATA / 'b5203.pgm'}")


@FUZZ
@given(text=mutated(MAP_TEXT))
def test_map_yamls_load_or_say_why(folder: Path, text: str) -> None:
    path = write(folder / "map.yaml", text)
    try:
        occ_map = quick(load_map, path)
    except (MapError, InputError):
        return
    assert occ_map.resolution > 0 and math.isfinite(occ_map.resolution)


PGM_HEADERS = ["P5\n{w} {h}\n255\n", "P5\n{w} {h}\n65535\n", "P2\n{w} {h}\n255\n", "P5\n# c\n{w} {h}\n{w}\n",
               "P6\n{w} {h}\n255\n", "P5 {w} {h} 0\n", "P5\n{w}\n"]
#: Claimed sides stay small in this process; the table test sends the 30000 x 30000 ones to a child.
SIDE = st.integers(-2, 3000)


@FUZZ
@given(header=st.sampled_from(PGM_HEADERS), width=SIDE, height=SIDE, body=st.binary(max_size=4096),
       suffix=st.sampled_from([".pgm", ".png", ".bmp"]), edit=mutated("", ["9" * 12, "-", "\n", "#", " ", "P5"]))
def test_map_images_load_or_say_why(folder: Path, header: str, width: int, height: int, body: bytes, suffix: str,
                                    edit: str) -> None:
    """A map YAML of the shipped fields around an image whose header says anything and whose body is short."""
    image = write(folder / f"map_image{suffix}", (header.format(w=width, h=height) + edit).encode("latin-1", "replace")
                  + body)
    path = write(folder / "map.yaml", MAP_TEXT.replace(str(NAV_DATA / "b5203.pgm"), str(image)))
    try:
        occ_map = quick(load_map, path)
    except (MapError, InputError):
        return
    assert occ_map.data.ndim == 2


# -- pose files ----------------------------------------------------------------------------------------------

POSE_TEXT = (NAV_DATA / "b5203.txt").read_text(encoding="utf-8")
NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers().map(str),
                    st.sampled_from(["1e308", "-1e308", "1e999", "nan", "0x10", "1_0", "", " ", "--1", "9" * 5000]))


@st.composite
def pose_lines(draw: st.DrawFn) -> str:
    rows = []
    for _ in range(draw(st.integers(0, 6))):
        fields = draw(st.lists(NUMBERS, min_size=5, max_size=9))
        prefix = draw(st.sampled_from(["", "", "station_pose: ", "STATION_POSE:", "# "]))
        rows.append(prefix + draw(st.sampled_from([", ", ",", " , ", " "])).join(fields))
    return "\n".join(rows)


@FUZZ
@given(text=st.one_of(mutated(POSE_TEXT, [*TOKENS, "station_pose:", "station_pose: 1, 2"]), pose_lines()))
def test_pose_files_load_or_say_why(folder: Path, text: str) -> None:
    path = write(folder / "poses.txt", text)
    try:
        poses = quick(load_poses, path)
    except (PoseFileError, InputError):
        return
    for pose in (*poses.goals, *([poses.station] if poses.station else [])):
        assert all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)), pose


# -- PCD headers ---------------------------------------------------------------------------------------------


def _pcd_bytes(folder: Path, encoding: str, coloured: bool) -> bytes:
    rng = np.random.default_rng(3)
    points = rng.uniform(-1, 1, (12, 3)).astype(np.float32)
    colours = rng.integers(0, 255, (12, 3), dtype=np.uint8) if coloured else None
    path = folder / f"valid_{encoding}_{coloured}.pcd"
    write_pcd(path, PointCloud(points, colours, 4, 3), encoding=encoding)
    return path.read_bytes()


PCD_TOKENS = [*TOKENS, "COUNT 3 1 1", "COUNT 1 1 1 2", "WIDTH 4294967296", "HEIGHT 0", "POINTS 99999999999",
              "SIZE 8 8 8", "TYPE U U U", "FIELDS x y", "FIELDS _ x y z", "DATA binary_compressed", "DATA ascii",
              "DATA lzf", "# comment"]


@FUZZ
@given(data=st.data(), encoding=st.sampled_from(["ascii", "binary", "binary_compressed"]), coloured=st.booleans())
def test_pcd_headers_read_or_say_why(folder: Path, data: st.DataObject, encoding: str, coloured: bool) -> None:
    """A valid small PCD (each encoding, with and without colour) whose header text is mutated, body kept."""
    valid = _pcd_bytes(folder, encoding, coloured)
    split = valid.index(b"\nDATA ") + 1
    split = valid.index(b"\n", split) + 1
    header = data.draw(mutated(valid[:split].decode("ascii"), PCD_TOKENS))
    path = write(folder / "cloud.pcd", header.encode("utf-8", "surrogatepass") + valid[split:])
    try:
        cloud = quick(read_pcd, path)
    except (CloudFileError, InputError):
        return
    assert len(cloud.points) == cloud.width * cloud.height
