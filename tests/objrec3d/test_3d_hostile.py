"""Hostile and degenerate point clouds: refused in one line naming the file and what is wrong, or, when
valid, handled in bounded time. Files are built in tmp_path from a few lines each; a header that claims
gigabytes needs only a few bytes.

The command-line cases run ``objrec-detect`` in a child (tests/hostile/harness.py) and measure its CPU time and its
own peak memory. The rest call the readers and the modules directly; what they promise in time is bounded in the
CPU time of this thread, or, where the danger is blocking rather than working, by a hang guard of minutes.
"""

from __future__ import annotations

import logging
import os
import struct
import sys
import time
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import objrec_apps
from objrec3d import FileSource, PointCloud, RGBDSource, ShapeDetector, read_cloud, read_pcd, write_pcd
from objrec3d.normals import adaptive_normals, grid_normals, knn_normals, no_surface
from objrec3d.pcd import MAX_HEADER_BYTES, CloudFileError
from objrec_core import SourceError
from objrec_ros.decode import DecodeError, pointcloud2_arrays
from strictio import InputError, LimitError
from tests.hostile import harness

SHAPE = str(Path(objrec_apps.__file__).parent / "systems" / "shape_demo.yaml")
SECONDS, MEGABYTES = harness.CPU_SECONDS_LIMIT, harness.MEMORY_LIMIT_MB  # CPU seconds, peak memory of a command


# -- files ------------------------------------------------------------------------------------------------------
def pcd_header(fields: str = "x y z", sizes: str = "4 4 4", types: str = "F F F", counts: str = "1 1 1",
               width: int = 2, height: int = 1, data: str = "ascii", comments: int = 0) -> bytes:
    lines = ["# .PCD v0.7", *(f"# comment line {i} of a long header" for i in range(comments)), "VERSION 0.7",
             f"FIELDS {fields}", f"SIZE {sizes}", f"TYPE {types}", f"COUNT {counts}", f"WIDTH {width}",
             f"HEIGHT {height}", "VIEWPOINT 0 0 0 1 0 0 0", f"POINTS {width * height}", f"DATA {data}"]
    return ("\n".join(lines) + "\n").encode("ascii")


def scene(count: int = 400, seed: int = 1) -> np.ndarray:
    """Points in front of the camera, inside the shape system's distance band."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.3, 0.3, count), rng.uniform(-0.3, 0.3, count),
                            rng.uniform(0.6, 1.2, count)]).astype(np.float32)


def ascii_lines(points: np.ndarray) -> bytes:
    return "".join(" ".join(f"{v:.6f}" for v in row) + "\n" for row in points).encode("ascii")


def ply(points: np.ndarray, comments: int = 0, body: bytes | None = None, count: int | None = None,
        fmt: str = "ascii", colours: bool = False) -> bytes:
    head = ["ply", f"format {fmt} 1.0", *(f"comment padding line {i:04d} of a long header" for i in range(comments)),
            f"element vertex {len(points) if count is None else count}",
            "property float x", "property float y", "property float z",
            *(["property uchar red", "property uchar green", "property uchar blue"] if colours else []),
            "end_header"]
    return ("\n".join(head) + "\n").encode("ascii") + (ascii_lines(points) if body is None else body)


def write(folder: Path, name: str, data: bytes) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


# -- the command in a child ---------------------------------------------------------------------------------------
def detect(source: Path, *extra: str) -> harness.Outcome:
    """``objrec-detect`` of the shape system on ``source`` (one frame unless ``extra`` says otherwise) in a child,
    in the source's folder, measured by tests/hostile/harness.py (exit code, stderr, CPU time, its own peak
    memory)."""
    return harness.run([sys.executable, "-m", "objrec_apps.detect", SHAPE, "--source", source, "-n", "1", *extra],
                       source.parent)


def assert_refused(run: harness.Outcome, *words: str) -> None:
    """Exit 2, one stderr line holding each of ``words`` (the file, the field or line), no traceback, in time
    and memory."""
    lines = run.stderr.strip().splitlines()
    assert run.exit_code == 2, run.describe()
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.describe()
    for word in words:
        assert word in lines[0], f"{word!r} not in the message\n{run.describe()}"
    assert run.cpu_seconds < SECONDS and run.max_rss_mb < MEGABYTES, run.describe()


# -- refusals through the command ---------------------------------------------------------------------------------
def _compressed_claiming(points: int, uncompressed: int) -> bytes:
    literal = b"\x1f" + bytes(32)  # LZF: control byte 31, then 32 literal bytes
    return (pcd_header("x y z rgb", "4 4 4 4", "F F F U", "1 1 1 1", points, 1, "binary_compressed")
            + struct.pack("<II", len(literal), uncompressed % 2**32) + literal)


REFUSED = {
    # name: (file name, bytes, words the one line must hold)
    "compressed-claims-4-GB": ("bomb.pcd", lambda: _compressed_claiming(268_435_456, 268_435_456 * 16),
                               ["bomb.pcd", "268,435,456 points", "OBJREC_MAX_CLOUD_POINTS"]),
    "compressed-sizes-claim-16-MB": ("lzf.pcd", lambda: _compressed_claiming(1_000_000, 16_000_000),
                                     ["lzf.pcd", "33 compressed bytes cannot decompress to the 16,000,000 bytes"]),
    "binary-claims-a-billion": ("billion.pcd", lambda: pcd_header(width=100_000, height=10_000, data="binary"),
                                ["billion.pcd", "1,000,000,000 points", "OBJREC_MAX_CLOUD_POINTS"]),
    "count-3-on-x": ("count3.pcd", lambda: pcd_header(counts="3 1 1", width=2, data="binary") + bytes(40),
                     ["count3.pcd", "field x has COUNT 3"]),
    "rgb-count-2": ("rgb2.pcd", lambda: pcd_header("x y z rgb", "4 4 4 4", "F F F U", "1 1 1 2", data="binary")
                    + bytes(40), ["rgb2.pcd", "field rgb has COUNT 2"]),
    "size-type-mismatch": ("size.pcd", lambda: pcd_header(sizes="4 4 2") + b"1 2 3\n4 5 6\n",
                           ["size.pcd", "field z has unsupported TYPE F SIZE 2"]),
    "ascii-garbage": ("garbage.pcd", lambda: pcd_header() + b"1 2 3\n1 x 3\n",
                      ["garbage.pcd", "line 13 is not 3 numbers", "1 x 3"]),
    "ply-garbage-body": ("garbage.ply", lambda: ply(scene(20), body=b"1 2 3\n" * 5 + b"abc def ghi\n" * 15),
                         ["garbage.ply", "line 13 is not 3 numbers", "abc def ghi"]),
    "ply-claims-a-trillion": ("trillion.ply", lambda: ply(scene(2), count=10**12),
                              ["trillion.ply", "element vertex", "OBJREC_MAX_CLOUD_POINTS"]),
    "ply-fewer-vertices": ("short.ply", lambda: ply(scene(20), count=30), ["short.ply", "20 of 30 points"]),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_hostile_cloud_files_are_refused_in_one_line(tmp_path: Path, case: str) -> None:
    name, data, words = REFUSED[case]
    assert_refused(detect(write(tmp_path, name, data())), *words)


def test_a_compressed_bomb_is_refused_before_it_takes_memory(tmp_path: Path) -> None:
    # Just under the point limit, so that only the LZF sizes can refuse it: 1.9 GB claimed by 33 bytes.
    path = write(tmp_path, "bomb.pcd", _compressed_claiming(19_999_999, 19_999_999 * 16))
    assert_refused(detect(path), "bomb.pcd", "cannot decompress to the 319,999,984 bytes")


# -- degenerate clouds through the command ------------------------------------------------------------------------
def _grid(point: list[float], width: int = 640, height: int = 480) -> np.ndarray:
    return np.tile(np.asarray(point, np.float32), (height, width, 1))


DEGENERATE = {
    # name: (the cloud, the reason the shape detector gives)
    "all-the-same-point-organized": (lambda: PointCloud(_grid([0.05, -0.02, 0.9])), "all one point"),
    "all-the-same-point-unorganized": (lambda: PointCloud(_grid([0.05, -0.02, 0.9]).reshape(-1, 3)), "all one point"),
    "two-distinct-points": (lambda: PointCloud(np.where((np.arange(307_200) % 2 == 0)[:, None],
                                                        np.float32([0.0, 0.0, 1.0]), np.float32([0.1, 0.0, 1.2]))),
                            "on one line"),
    "collinear-organized": (lambda: PointCloud(np.stack([np.linspace(0, 0.5, 19_200), np.linspace(0, 0.2, 19_200),
                                                         np.linspace(0.8, 1.1, 19_200)], -1).reshape(120, 160, 3)),
                            "on one line"),
    "nan-only": (lambda: PointCloud(np.full((120, 160, 3), np.nan, np.float32)), "0 valid"),
}


@pytest.mark.parametrize("case", list(DEGENERATE))
def test_degenerate_clouds_give_no_object_quickly_and_say_why(tmp_path: Path, case: str) -> None:
    make, reason = DEGENERATE[case]
    path = tmp_path / "degenerate.pcd"
    write_pcd(path, make())
    run = detect(path, "--explain")
    assert run.exit_code == 0 and "Traceback" not in run.stderr, run.describe()
    assert run.cpu_seconds < SECONDS and run.max_rss_mb < MEGABYTES, run.describe()  # the same point: ~10 minutes
    assert '"objects":[]' in run.stdout.replace(" ", ""), run.stdout
    assert reason in run.stderr, run.describe()


# -- folders ------------------------------------------------------------------------------------------------------
def test_a_folder_skips_a_bad_cloud_with_one_warning_and_reads_the_rest(tmp_path: Path) -> None:
    (tmp_path / "clouds").mkdir()
    write_pcd(tmp_path / "clouds" / "a.pcd", PointCloud(scene(seed=1)))
    write(tmp_path, "clouds/b_bad.pcd", b"this is no point cloud\n")
    write(tmp_path, "clouds/c.ply", ply(scene(seed=2)))
    write(tmp_path, "clouds/d_big.pcd", pcd_header(width=10**9, data="binary"))
    run = detect(tmp_path / "clouds", "-n", "10")
    assert run.exit_code == 0 and "Traceback" not in run.stderr, run.describe()
    assert len([line for line in run.stdout.splitlines() if line.startswith("{")]) == 2
    warnings = [line for line in run.stderr.splitlines() if "skipped" in line]
    assert len(warnings) == 2, run.describe()
    assert "b_bad.pcd: not a PCD file" in warnings[0] and "d_big.pcd" in warnings[1]
    assert "OBJREC_MAX_CLOUD_POINTS" in warnings[1]


def test_a_folder_of_only_bad_clouds_is_an_error_naming_the_folder(tmp_path: Path) -> None:
    write(tmp_path, "clouds/a_bad.pcd", b"this is no point cloud\n")
    write(tmp_path, "clouds/b_bad.ply", ply(scene(3), body=b"x y z\n" * 3))
    run = detect(tmp_path / "clouds")
    lines = run.stderr.strip().splitlines()
    assert run.exit_code == 2 and "Traceback" not in run.stderr and run.cpu_seconds < SECONDS, run.describe()
    assert "a_bad.pcd" in lines[0] and "b_bad.ply: corrupt ascii data: line 8" in lines[1]
    assert lines[2].endswith("clouds: none of its 2 point-cloud files could be read") and len(lines) == 3


def test_the_file_source_skips_in_a_folder_but_refuses_a_single_bad_file(tmp_path: Path, caplog) -> None:
    (tmp_path / "c").mkdir()
    write_pcd(tmp_path / "c" / "b.pcd", PointCloud(scene(5)))
    write(tmp_path, "c/a.pcd", pcd_header(counts="3 1 1"))
    with caplog.at_level(logging.WARNING):
        frames = list(FileSource(str(tmp_path / "c")))
    assert [Path(f.source).name for f in frames] == ["b.pcd"] and frames[0].index == 1
    assert len(caplog.records) == 1 and "a.pcd: corrupt header: field x has COUNT 3" in caplog.text
    with pytest.raises(CloudFileError, match=r"a\.pcd: corrupt header"):
        list(FileSource(str(tmp_path / "c" / "a.pcd")))
    (tmp_path / "c" / "b.pcd").write_bytes(b"")
    with pytest.raises(SourceError, match="none of its 2 point-cloud files"):
        list(FileSource(str(tmp_path / "c")))


# -- the PCD reader ------------------------------------------------------------------------------------------------
def test_a_pcd_header_of_many_comment_lines_is_read_and_an_endless_one_refused(tmp_path: Path) -> None:
    points = scene(50)
    path = write(tmp_path, "long.pcd", pcd_header(width=50, data="binary", comments=500) + points.tobytes())
    np.testing.assert_array_equal(read_pcd(path).points, points)
    endless = write(tmp_path, "endless.pcd", b"# x\n" * (MAX_HEADER_BYTES // 4 + 10))
    with pytest.raises(CloudFileError, match=r"endless\.pcd: not a PCD file: no DATA line in its first 1,048,576"):
        read_pcd(endless)


@pytest.mark.parametrize(("header", "words"), [
    (pcd_header(counts="3 1 1"), "field x has COUNT 3; it must be 1"),
    (pcd_header(counts="0 1 1"), "field x has COUNT 0; it must be 1"),
    (pcd_header("x y z n", "4 4 4 4", "F F F F", "1 1 1 0"), "field n has COUNT 0; it must be at least 1"),
    (pcd_header("x y z n", "4 4 4 4", "F F F F", "1 1 1 100000"), "field n with COUNT 100000 makes a point over"),
    (pcd_header(sizes="4 4 3"), "field z has unsupported TYPE F SIZE 3"),
    (pcd_header(types="F F Q"), "field z has unsupported TYPE Q SIZE 4"),
    (pcd_header(sizes="4 4"), "FIELDS, SIZE, TYPE and COUNT have different lengths"),
    (pcd_header("x y x", counts="1 1 1"), "field x occurs more than once"),
    (pcd_header(counts="1 1 x"), "COUNT of field z 'x' is not a whole number"),
    (pcd_header().replace(b"WIDTH 2", b"WIDTH " + b"9" * 5000), "WIDTH '99999"),
    (pcd_header().replace(b"WIDTH 2", b"WIDTH -2"), "WIDTH '-2' is not a whole number"),
    (pcd_header().replace(b"POINTS 2", b"POINTS 3"), "POINTS 3 is not WIDTH 2 x HEIGHT 1"),
    (pcd_header("x y \x1b[31mz"), r"no z field (fields: x y \x1b[31mz)"),
])
def test_pcd_headers_that_make_no_cloud_name_the_file_and_the_field(tmp_path: Path, header: bytes, words: str) -> None:
    path = write(tmp_path, "h.pcd", header + b"1 2 3\n4 5 6\n")
    with pytest.raises(CloudFileError) as info:
        read_pcd(path)
    assert isinstance(info.value, InputError) and isinstance(info.value, SourceError)
    assert str(info.value).startswith(f"{path}: ") and words in str(info.value)
    assert "\x1b" not in str(info.value)


def test_the_cloud_points_limit_is_checked_from_the_header_and_can_be_raised(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "c.pcd"
    write_pcd(path, PointCloud(scene(200)), "binary_compressed")
    monkeypatch.setenv("OBJREC_MAX_CLOUD_POINTS", "100")
    with pytest.raises(LimitError, match=r"c\.pcd: header: WIDTH x HEIGHT: 200 points, over the limit of 100 points "
                                         r"\(set OBJREC_MAX_CLOUD_POINTS to raise it\)"):
        read_pcd(path)
    ply_path = write(tmp_path, "c.ply", ply(scene(200)))
    with pytest.raises(LimitError, match=r"c\.ply: header: element vertex: 200 points"):
        read_cloud(ply_path)
    monkeypatch.setenv("OBJREC_MAX_CLOUD_POINTS", "200")
    assert len(read_pcd(path)) == 200 and len(read_cloud(ply_path)) == 200


def test_ascii_pcd_lines_are_checked_one_by_one(tmp_path: Path) -> None:
    head = pcd_header(width=4)
    cases = {
        "cut.pcd": (head + b"1 2 3\n4 5 6\n7 8 9\n1 2", "truncated: line 15 ends after 2 of 3 values"),
        "short.pcd": (head + b"1 2 3\n4 5 6\n", "truncated: ascii data holds 2 of 4 points"),
        "long.pcd": (head + b"1 2 3\n" * 5, "more lines than the 4 points"),
        "wide.pcd": (head + b"1 2 3\n4 5 6 7\n" + b"1 2 3\n" * 2, "line 13 is not 3 numbers: '4 5 6 7'"),
        "nul.pcd": (head + b"1 2 3\n" * 3 + b"1 \x00\xff 3\n", r"line 15 is not 3 numbers: '1 \x00ÿ 3'"),
    }
    for name, (data, words) in cases.items():
        with pytest.raises(CloudFileError) as info:
            read_pcd(write(tmp_path, name, data))
        assert f"{name}: " in str(info.value) and words in str(info.value), str(info.value)
    odd = read_pcd(write(tmp_path, "odd.pcd", head + b"nan nan nan\ninf -inf 1\n1e999 0 1\n0.5 -0.25 1e-3\r\n\n"))
    assert odd.count_valid() == 1 and odd.points[3].tolist() == [0.5, -0.25, np.float32(1e-3)]


# -- the PLY reader ------------------------------------------------------------------------------------------------
def test_a_ply_header_over_4096_bytes_is_read(tmp_path: Path) -> None:
    points = scene(30)
    data = ply(points, comments=150)
    assert data.index(b"end_header") > 4096
    cloud = read_cloud(write(tmp_path, "long.ply", data))
    np.testing.assert_allclose(cloud.points, points, atol=1e-6)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_vertices_and_colours_read_in_every_format_after_another_element(tmp_path: Path, fmt: str) -> None:
    points = scene(6)
    colours = np.arange(18, dtype=np.uint8).reshape(6, 3) * 13
    head = (f"ply\nformat {fmt} 1.0\ncomment made by hand\nelement camera 1\nproperty float view_px\n"
            "element vertex 6\nproperty double x\nproperty float y\nproperty float z\nproperty uchar red\n"
            "property uchar green\nproperty uchar blue\nelement face 0\nproperty list uchar int vertex_indices\n"
            "end_header\n").encode("ascii")
    if fmt == "ascii":
        body = b"0.5\n" + b"".join(f"{p[0]:.9g} {p[1]:.9g} {p[2]:.9g} {c[0]} {c[1]} {c[2]}\n".encode()
                                   for p, c in zip(points, colours, strict=True))
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        table = np.zeros(6, [("x", order + "f8"), ("y", order + "f4"), ("z", order + "f4"), ("rgb", "u1", 3)])
        table["x"], table["y"], table["z"], table["rgb"] = points[:, 0], points[:, 1], points[:, 2], colours
        body = np.float32(0.5).astype(order + "f4").tobytes() + table.tobytes()
    cloud = read_cloud(write(tmp_path, "v.ply", head + body))
    np.testing.assert_array_equal(cloud.points, points)
    np.testing.assert_array_equal(cloud.colors, colours)


def test_ply_bodies_that_do_not_match_the_header_are_refused(tmp_path: Path) -> None:
    points = scene(20)
    binary = ply(points, fmt="binary_little_endian", body=points.tobytes())
    cases = {
        "garbage.ply": (ply(points, body=ascii_lines(points[:4]) + b"1 2 nope\n"),
                        "corrupt ascii data: line 12 is not 3 numbers: '1 2 nope'"),
        "fewer.ply": (ply(points, count=25), "truncated: ascii data holds 20 of 25 points"),
        "more.ply": (ply(points, count=15), "more lines than the 15 vertices"),
        "cut.ply": (binary[:-5], "truncated: 235 bytes of element data, 20 vertices need 240"),
        "nox.ply": (ply(points).replace(b"property float x\n", b""), "element vertex has no property x"),
        "twice.ply": (ply(points).replace(b"property float y", b"property float x"), "property x occurs twice"),
        "type.ply": (ply(points).replace(b"property float z", b"property quad z"), "property z has unknown type"),
        "format.ply": (ply(points).replace(b"ascii 1.0", b"text 1.0"), "unknown format 'text'"),
        "digits.ply": (ply(points).replace(b"vertex 20", b"vertex " + b"9" * 5000), "count '99999"),
        "noend.ply": (b"ply\nformat ascii 1.0\nelement vertex 0\n", "corrupt PLY header: no end_header"),
        "end.ply": (ply(points).replace(b"end_header", b"end"), "line 7: 'end' is not a PLY header line"),
        "lists.ply": (ply(points).replace(b"property float z", b"property float z\nproperty list uchar int n"),
                      "element vertex has list properties"),
        "x.ply": (b"garbage", "not a PLY file"),
    }
    for name, (data, words) in cases.items():
        with pytest.raises(CloudFileError) as info:
            read_cloud(write(tmp_path, name, data))
        assert str(info.value).startswith(f"{tmp_path / name}: ") and words in str(info.value), str(info.value)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_named_like_a_cloud_is_refused_at_once(tmp_path: Path) -> None:
    for name in ("pipe.ply", "pipe.pcd"):
        os.mkfifo(tmp_path / name)
        start = time.thread_time()  # a reader that opened the FIFO would block here: pytest-timeout is the guard
        with pytest.raises(CloudFileError, match=f"{name}: is a FIFO"):
            read_cloud(tmp_path / name)
        assert time.thread_time() - start < 1.0


# -- PointCloud2 ---------------------------------------------------------------------------------------------------
def test_a_pointcloud2_claiming_more_points_than_the_limit_is_refused_before_decoding() -> None:
    field = [SimpleNamespace(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyz")]
    message = SimpleNamespace(is_bigendian=False, width=100_000, height=100_000, point_step=12,
                              row_step=1_200_000, fields=field, data=b"\0" * 12)
    with pytest.raises(DecodeError, match=r"100000 x 100000 PointCloud2: 10,000,000,000 points, over the limit .*"
                                          r"OBJREC_MAX_CLOUD_POINTS"):
        pointcloud2_arrays(message)


# -- normals and the shape detector on degenerate clouds ---------------------------------------------------------------
def test_normals_of_points_that_span_no_surface_are_nan_and_cheap() -> None:
    same = np.tile([0.1, 0.2, 1.0], (307_200, 1))
    start = time.process_time()  # CPU time of every thread (the k-d tree search runs on several), not wall-clock
    assert np.isnan(adaptive_normals(same)).all()  # took minutes: a k-d tree cannot split copies of one point
    assert time.process_time() - start < 1.0
    t = np.linspace(0.0, 1.0, 5000)[:, None]
    line = np.float32([0.1, 0.2, 0.9]) + t * np.float32([0.5, 0.2, 0.3])
    assert np.isnan(knn_normals(line, 20)).all()
    grid = PointCloud(line.reshape(50, 100, 3).astype(np.float32))
    assert np.isnan(grid_normals(grid, np.arange(5000))).all()
    assert no_surface(same) == "the points are all one point" and no_surface(line) == "the points lie on one line"
    assert no_surface(scene(100)) == ""


def test_copies_of_one_point_beside_a_surface_leave_the_surface_its_normals() -> None:
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-0.2, 0.2, (2, 20_000))
    table = np.stack([u, v, 1.0 + 0.0005 * rng.standard_normal(20_000)], axis=1)
    cloud = np.concatenate([np.tile([0.0, 0.0, 0.8], (30_000, 1)), table])
    start = time.process_time()
    normals = adaptive_normals(cloud, origin=np.zeros(3))
    # Took minutes. CPU time of every thread: ~3.6 s on 2 cores for ~2.5 s of wall time when the machine is idle.
    assert time.process_time() - start < 10.0
    good = normals[30_000:]
    assert np.isfinite(good[:, 0]).mean() > 0.99
    assert np.median(np.abs(good[np.isfinite(good[:, 0]), 2])) > 0.99  # facing the camera, along -z


def test_the_shape_detector_says_why_a_degenerate_cloud_has_no_object() -> None:
    detector = ShapeDetector(shape="cylinder+sphere+plane", min_inliers=3)
    same = PointCloud(np.tile(np.float32([0.0, 0.0, 1.0]), (120, 160, 1)))
    result = detector.detect(same)
    assert result == []
    assert result.reason == ("too few points: 0 with normals (of 19200 valid) < min_inliers 3; the points are "
                             "all one point, no surface to fit")
    line = detector.detect(PointCloud(np.float32([[0, 0, 1], [0, 0, 1], [0.1, 0, 1]])))
    assert line == []
    assert line.reason.endswith("the points lie on one line, no surface to fit")


def test_an_rgbd_image_claiming_gigapixels_is_refused_before_open3d_decodes_it(tmp_path: Path) -> None:
    header = struct.pack(">IIBBBBB", 30_000, 30_000, 16, 0, 0, 0, 0)
    bomb = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + header + zlib.crc32(b"IHDR" + header).to_bytes(4)
    write(tmp_path, "depth.png", bomb)
    write(tmp_path, "color.png", bomb)
    source = RGBDSource("rgbd", str(tmp_path / "color.png"), str(tmp_path / "depth.png"))
    with pytest.raises(LimitError, match=r"depth\.png: image of 30000x30000: 900,000,000 pixels.*OBJREC_MAX_IMAGE"):
        source.read()
