"""PCD reading through pypcd4 and writing: real scans bit for bit, hand-built files, refusals, atomic saves."""

from __future__ import annotations

import hashlib
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

from objrec3d import CloudFileError, PointCloud, read_pcd, write_pcd
from objrec3d import pcd as pcd_module
from strictio import OutputError

# What the shared scans hold, taken from the pure-Python LZF reader this one replaced: layout, finite points,
# the first finite point and its colour, and SHA-256 (first 16 hex digits) of the point and colour bytes,
# NaN bit patterns included.
SCANS = {
    "table_scene_mug_stereo_textured": (209_280, 6538, [-0.3819099962711334, -0.448199987411499, 2.0257999897003174],
                                        [67, 67, 62], "f4e93adb55a7d56c", "dab3626fcb6eae85"),
    "milk_cartoon_all_small_clorox": (241_407, 10814, [0.9656456708908081, -0.8480228781700134, 1.9919999837875366],
                                      [88, 85, 68], "00d23eb1a511acae", "8fcc3b406fa90cc1"),
    "office1": (254_456, 8979, [-2.2400128841400146, -1.6818710565567017, 3.9070000648498535],
                [166, 157, 147], "bdba61e94a2df3b2", "bdd4a216aa8d7261"),
}


def _digest(array: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()[:16]


@pytest.mark.realdata
@pytest.mark.parametrize("name", sorted(SCANS))
def test_the_shared_scans_read_bit_for_bit_with_layout_and_colours(shared_data, name: str) -> None:
    valid, first, point, colour, points_digest, colors_digest = SCANS[name]
    cloud = read_pcd(shared_data / "clouds" / f"{name}.pcd")
    assert (cloud.width, cloud.height, len(cloud), cloud.count_valid()) == (640, 480, 307_200, valid)
    assert cloud.points.dtype == np.float32 and cloud.colors is not None and cloud.colors.shape == (307_200, 3)
    assert int(np.argmax(cloud.valid_mask())) == first
    assert cloud.points[first].tolist() == point and cloud.colors[first].tolist() == colour
    assert (_digest(cloud.points), _digest(cloud.colors)) == (points_digest, colors_digest)


def _literal_lzf(data: bytes) -> bytes:
    """An LZF stream of literal runs only (at most 32 bytes each): an encoder independent of the library."""
    return b"".join(bytes([len(data[i : i + 32]) - 1]) + data[i : i + 32] for i in range(0, len(data), 32))


def _compressed_pcd(planes: bytes, points: int, stream: bytes | None = None, fields: str = "x y z rgba",
                    sizes: str = "4 4 4 4", types: str = "F F F U", counts: str = "1 1 1 1") -> bytes:
    stream = _literal_lzf(planes) if stream is None else stream
    header = (f"# .PCD v0.7\nVERSION 0.7\nFIELDS {fields}\nSIZE {sizes}\nTYPE {types}\nCOUNT {counts}\n"
              f"WIDTH {points}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {points}\nDATA binary_compressed\n")
    return header.encode("ascii") + struct.pack("<II", len(stream), len(planes)) + stream


def test_field_planes_with_extra_and_multi_valued_fields_decode_to_points_and_colours(tmp_path) -> None:
    # binary_compressed stores each field for all points in turn: x..., normal (3 per point)..., y..., and so on.
    xyz = np.array([[0.5, -1.25, 2.0], [np.nan, np.nan, np.nan], [3.0, 0.0, -0.125]], np.float32)
    rgba = np.array([0xFF112233, 0x00000000, 0x80FF0080], np.uint32)  # A R G B, as PCL packs them
    normal = np.arange(9, dtype=np.float32)
    intensity = np.array([7, 8, 9], np.uint16)
    planes = b"".join(a.tobytes() for a in (xyz[:, 0], normal, xyz[:, 1], intensity, xyz[:, 2], rgba))
    path = tmp_path / "planes.pcd"
    path.write_bytes(_compressed_pcd(planes, 3, fields="x normal y intensity z rgba", sizes="4 4 4 2 4 4",
                                     types="F F F U F U", counts="1 3 1 1 1 1"))
    cloud = read_pcd(path)
    np.testing.assert_array_equal(cloud.points, xyz)
    assert cloud.colors.tolist() == [[0x11, 0x22, 0x33], [0, 0, 0], [0xFF, 0x00, 0x80]]


@pytest.mark.parametrize(("stream_of", "problem"), [
    (lambda planes: _literal_lzf(planes[:-4]), "corrupt compressed data: .*is 32, but got 28"),
    (lambda planes: _literal_lzf(planes + b"\0" * 4), "corrupt compressed data: .*more than the 32 bytes"),
    (lambda planes: bytes([0xE0, 5, 9]) + planes, "corrupt compressed data"),  # refers before the start
])
def test_lzf_streams_that_do_not_decode_to_the_declared_size_are_refused(tmp_path, stream_of, problem) -> None:
    planes = np.arange(2 * 3, dtype=np.float32).tobytes() + np.zeros(2, np.uint32).tobytes()
    path = tmp_path / "bad.pcd"
    path.write_bytes(_compressed_pcd(planes, 2, stream_of(planes)))
    with pytest.raises(CloudFileError, match=f"bad\\.pcd: {problem}"):
        read_pcd(path)


def test_headers_that_do_not_fit_a_point_cloud_are_refused(tmp_path) -> None:
    planes = np.zeros(8, np.float32).tobytes()
    cases = {
        "count.pcd": (_compressed_pcd(planes, 2, fields="x y z", sizes="4 4 4", types="F F F", counts="2 1 1"),
                      "field x has COUNT 2; it must be 1"),
        "size.pcd": (_compressed_pcd(planes, 2).replace(struct.pack("<II", len(_literal_lzf(planes)), 32),
                                                        struct.pack("<II", len(_literal_lzf(planes)), 40)),
                     "uncompressed size 40 bytes, 2 points need 32"),
        "type.pcd": (_compressed_pcd(planes, 2, types="F F F Q"), "field rgba has unsupported TYPE Q SIZE 4"),
    }
    for name, (data, problem) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(CloudFileError, match=f"{name}: corrupt.*{problem}"):
            read_pcd(tmp_path / name)


def test_only_regular_files_within_the_size_cap_are_read(tmp_path, monkeypatch) -> None:
    (tmp_path / "folder.pcd").mkdir()
    with pytest.raises(CloudFileError, match="folder\\.pcd: is a folder"):
        read_pcd(tmp_path / "folder.pcd")
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe.pcd")
        with pytest.raises(CloudFileError, match="pipe\\.pcd: is a FIFO"):
            read_pcd(tmp_path / "pipe.pcd")
    path = tmp_path / "big.pcd"
    write_pcd(path, _plane(10, 10))
    monkeypatch.setattr(pcd_module, "MAX_PCD_BYTES", 1000)
    with pytest.raises(CloudFileError, match=r"big\.pcd: is 1,.* bytes, over the limit of 1,000 bytes"):
        read_pcd(path)


def test_without_pypcd4_a_compressed_file_says_what_to_install(tmp_path, monkeypatch) -> None:
    path = tmp_path / "c.pcd"
    path.write_bytes(_compressed_pcd(np.zeros(8, np.float32).tobytes(), 2))
    write_pcd(tmp_path / "b.pcd", _plane(2, 2), "binary")
    monkeypatch.setitem(sys.modules, "pypcd4", None)
    with pytest.raises(CloudFileError, match=r"c\.pcd: reading binary_compressed PCD needs pypcd4.*objrec\[3d\]"):
        read_pcd(path)
    assert len(read_pcd(tmp_path / "b.pcd")) == 4  # binary needs only NumPy


def _plane(width: int, height: int, seed: int = 1) -> PointCloud:
    """A noisy organized plane with a few holes and two colours: LZF shrinks it."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    points = np.stack([u * 1e-3, v * 1e-3, 0.8 + rng.normal(0, 1e-3, u.shape).astype(np.float32)], axis=-1)
    points[::7, ::5] = np.nan
    colors = np.zeros((height, width, 3), np.uint8)
    colors[:, width // 3 :] = (250, 128, 3)
    return PointCloud(points, colors)


@pytest.mark.parametrize("encoding", ["ascii", "binary", "binary_compressed"])
def test_writing_then_reading_gives_back_every_bit_of_points_colours_and_layout(tmp_path, encoding: str) -> None:
    cloud = _plane(160, 120)
    path = tmp_path / "plane.pcd"
    write_pcd(path, cloud, encoding)
    assert f"DATA {encoding}\n".encode() in path.read_bytes()[:400]
    back = read_pcd(path)
    assert (back.width, back.height) == (160, 120)
    assert back.points.tobytes() == cloud.points.tobytes()  # NaN holes and the last float32 bit included
    np.testing.assert_array_equal(back.colors, cloud.colors)
    bare = PointCloud(cloud.points[:50])
    write_pcd(path, bare, encoding)
    again = read_pcd(path)
    assert again.colors is None and again.points.tobytes() == bare.points.tobytes()
    write_pcd(path, PointCloud.empty(), encoding)
    assert len(read_pcd(path)) == 0


def test_data_lzf_cannot_shrink_is_written_as_binary_and_still_reads_back(tmp_path) -> None:
    rng = np.random.default_rng(3)
    cloud = PointCloud(rng.uniform(-1, 1, (20, 3)).astype(np.float32))
    path = tmp_path / "noise.pcd"
    write_pcd(path, cloud, "binary_compressed")
    assert b"DATA binary\n" in path.read_bytes()
    assert read_pcd(path).points.tobytes() == cloud.points.tobytes()


def test_open3d_reads_what_is_written_in_every_encoding(tmp_path) -> None:
    import open3d as o3d

    cloud = _plane(64, 48)
    for encoding in ("ascii", "binary", "binary_compressed"):
        path = tmp_path / f"{encoding}.pcd"
        write_pcd(path, cloud, encoding)
        theirs = o3d.io.read_point_cloud(str(path), remove_nan_points=False)
        np.testing.assert_array_equal(np.asarray(theirs.points, np.float32), cloud.points)


def test_a_save_replaces_the_file_whole_and_a_failed_one_leaves_it(tmp_path) -> None:
    path = tmp_path / "scan.pcd"
    write_pcd(path, _plane(20, 10), "binary_compressed")
    write_pcd(path, _plane(30, 10), "ascii")
    assert (read_pcd(path).width, sorted(p.name for p in tmp_path.iterdir())) == (30, ["scan.pcd"])
    with pytest.raises(OutputError, match="does not exist"):
        write_pcd(tmp_path / "missing" / "scan.pcd", _plane(2, 2))
    (tmp_path / "taken.pcd").mkdir()
    with pytest.raises(OutputError, match="taken\\.pcd: cannot save"):
        write_pcd(tmp_path / "taken.pcd", _plane(2, 2))
    assert read_pcd(path).width == 30 and sorted(p.name for p in tmp_path.iterdir()) == ["scan.pcd", "taken.pcd"]
    with pytest.raises(ValueError, match="unknown PCD encoding 'lzf'"):
        write_pcd(path, _plane(2, 2), "lzf")


# -- PLY (objrec3d/ply.py): read by NumPy through strictio, never by Open3D ------------------------------------------
PLY_POINTS = np.array([[0.5, -1.25, 2.0], [1e-3, 3.5, -7.75], [10.0, 0.0, 0.125]], np.float32)
PLY_COLOURS = np.array([[255, 0, 10], [1, 2, 3], [128, 64, 32]], np.uint8)


def _ply_file(fmt: str, float_colours: bool = False) -> bytes:
    colour_type = "float" if float_colours else "uchar"
    head = ["ply", f"format {fmt} 1.0", "comment made by the test", "element vertex 3", "property float x",
            "property float y", "property float z", *(f"property {colour_type} {c}" for c in ("red", "green", "blue")),
            "property double quality", "element face 0", "property list uchar int vertex_indices", "end_header"]
    colours = PLY_COLOURS / 255.0 if float_colours else PLY_COLOURS
    if fmt == "ascii":
        rows = [" ".join([*map(repr, map(float, p)), *map(str, c), "0.5"]) for p, c in zip(PLY_POINTS, colours,
                                                                                       strict=True)]
        body = ("\n".join(rows) + "\n").encode("ascii")
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        colour_code = "f" if float_colours else "B"
        body = b"".join(struct.pack(f"{order}fff{colour_code * 3}d", *map(float, p), *c.tolist(), 0.5)
                        for p, c in zip(PLY_POINTS, colours, strict=True))
    return ("\n".join(head) + "\n").encode("ascii") + body


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
@pytest.mark.parametrize("float_colours", [False, True])
def test_ply_vertices_and_colours_read_in_every_format(tmp_path, fmt: str, float_colours: bool) -> None:
    from objrec3d.ply import read_ply

    path = tmp_path / "cloud.ply"
    path.write_bytes(_ply_file(fmt, float_colours))
    cloud = read_ply(path)
    assert np.array_equal(cloud.points.reshape(-1, 3), PLY_POINTS)
    assert np.array_equal(cloud.colors.reshape(-1, 3), PLY_COLOURS)


def test_a_ply_with_a_short_binary_body_names_the_bytes_missing(tmp_path) -> None:
    from objrec3d.ply import read_ply

    path = tmp_path / "short.ply"
    path.write_bytes(_ply_file("binary_little_endian")[:-10])
    with pytest.raises(CloudFileError, match=r"short\.ply: truncated: 59 bytes of element data, 3 vertices need 69"):
        read_ply(path)


def test_reading_a_ply_loads_no_open3d(tmp_path) -> None:
    path = tmp_path / "cloud.ply"
    path.write_bytes(_ply_file("binary_little_endian"))
    code = ("import sys; from objrec3d import read_cloud; cloud = read_cloud(sys.argv[1]); "
            "print(len(cloud.points.reshape(-1, 3)), 'open3d' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=300,
                            check=False)
    assert result.stdout.split() == ["3", "False"], result.stderr
