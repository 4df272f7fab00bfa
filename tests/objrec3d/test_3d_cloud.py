"""The cloud type, PCD/PLY reading and writing, and bad files."""

from __future__ import annotations

import numpy as np
import pytest

from objrec3d import CloudFileError, PointCloud, read_cloud, read_pcd, write_pcd


def _organized(seed: int = 0) -> PointCloud:
    rng = np.random.default_rng(seed)
    points = rng.uniform(-1, 1, (4, 5, 3)).astype(np.float32)
    points[1, 2] = np.nan
    colors = rng.integers(0, 255, (4, 5, 3), dtype=np.uint8)
    return PointCloud(points, colors)


def test_layout_and_selection_keep_an_organized_cloud_organized() -> None:
    cloud = _organized()
    assert (cloud.width, cloud.height, len(cloud), cloud.is_organized) == (5, 4, 20, True)
    assert cloud.points.dtype == np.float32 and cloud.colors.dtype == np.uint8
    assert cloud.count_valid() == 19
    keep = cloud.points[:, 0] > 0
    chosen = cloud.select(keep)
    assert (chosen.width, chosen.height) == (5, 4)
    assert np.isnan(chosen.points[~keep]).all()
    assert chosen.count_valid() == int((keep & cloud.valid_mask()).sum())
    flat = PointCloud(cloud.points[cloud.valid_mask()])
    assert not flat.is_organized and len(flat.select(flat.points[:, 0] > 0)) == int((flat.points[:, 0] > 0).sum())


def test_numpy_and_open3d_round_trip_in_one_call_each() -> None:
    cloud = _organized()
    o3d_cloud = cloud.to_open3d()
    assert len(o3d_cloud.points) == 19 and o3d_cloud.has_colors()
    back = PointCloud.from_open3d(cloud.to_open3d(keep_invalid=True), width=5, height=4)
    assert back.is_organized
    np.testing.assert_allclose(back.points, cloud.points, equal_nan=True)
    np.testing.assert_array_equal(back.colors, cloud.colors)
    plain = PointCloud.from_numpy(np.zeros((7, 3)))
    assert len(plain) == 7 and plain.colors is None


@pytest.mark.parametrize("bad", [np.zeros((5, 2)), np.zeros(9), [["a", "b", "c"]]])
def test_bad_arrays_are_refused_clearly(bad: object) -> None:
    with pytest.raises(ValueError, match="points must be"):
        PointCloud(bad)


@pytest.mark.parametrize("encoding", ["ascii", "binary", "binary_compressed"])
def test_pcd_round_trip_in_every_encoding(tmp_path, encoding: str) -> None:
    cloud = _organized()
    path = tmp_path / f"c_{encoding}.pcd"
    write_pcd(path, cloud, encoding)
    back = read_pcd(path)
    assert (back.width, back.height) == (5, 4)
    np.testing.assert_allclose(back.points, cloud.points, rtol=1e-6, equal_nan=True)
    np.testing.assert_array_equal(back.colors, cloud.colors)


def _smooth(width: int = 40, height: int = 30) -> PointCloud:
    """A sloped plane with two colours: data LZF shrinks, so binary_compressed stays compressed."""
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    points = np.stack([u * 0.01, v * 0.01, 1.0 + 0.001 * u], axis=-1)
    colors = np.zeros((height, width, 3), np.uint8)
    colors[:, width // 2 :] = (200, 30, 10)
    return PointCloud(points, colors)


def test_corrupt_and_truncated_pcd_files_name_the_file_and_the_problem(tmp_path) -> None:
    cloud = _organized()
    good = tmp_path / "good.pcd"
    write_pcd(good, _smooth(), "binary_compressed")
    raw = good.read_bytes()
    assert b"DATA binary_compressed\n" in raw
    sizes_end = raw.index(b"DATA binary_compressed\n") + 31  # the header, then the two 4-byte sizes
    cases = {
        "truncated.pcd": (raw[: len(raw) - 40], "truncated"),
        "garbage.pcd": (b"\x00\x01 not a cloud at all", "not a PCD file"),
        "noheader.pcd": (b"hello\nworld\n", "not a PCD file"),
        "badcount.pcd": (raw.replace(b"POINTS 1200", b"POINTS 1201"), "POINTS 1201"),
        "badlzf.pcd": (raw[:sizes_end] + b"\xff" * (len(raw) - sizes_end), "corrupt compressed data"),
    }
    for name, (data, words) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(CloudFileError, match=words) as info:
            read_pcd(path)
        assert name in str(info.value)
    binary = tmp_path / "b.pcd"
    write_pcd(binary, cloud, "binary")
    (tmp_path / "bt.pcd").write_bytes(binary.read_bytes()[:-7])
    with pytest.raises(CloudFileError, match="truncated"):
        read_pcd(tmp_path / "bt.pcd")
    ascii_path = tmp_path / "a.pcd"
    write_pcd(ascii_path, cloud, "ascii")
    (tmp_path / "at.pcd").write_text(ascii_path.read_text().rsplit("\n", 3)[0])
    with pytest.raises(CloudFileError, match="truncated"):
        read_pcd(tmp_path / "at.pcd")
    with pytest.raises(CloudFileError, match="file not found"):
        read_pcd(tmp_path / "missing.pcd")


def test_ply_files_read_and_a_ply_without_points_is_an_empty_cloud(tmp_path) -> None:
    import open3d as o3d

    cloud = _organized()
    path = tmp_path / "c.ply"
    o3d.io.write_point_cloud(str(path), cloud.to_open3d())
    back = read_cloud(path)
    assert len(back) == 19
    empty = tmp_path / "empty.ply"
    empty.write_text("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                     "property float z\nend_header\n")
    assert len(read_cloud(empty)) == 0
    broken = tmp_path / "broken.ply"
    broken.write_text("ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                      "property float z\nend_header\n1 2 3\n")
    with pytest.raises(CloudFileError, match="broken\\.ply"):
        read_cloud(broken)
    (tmp_path / "x.ply").write_bytes(b"garbage")
    with pytest.raises(CloudFileError, match="not a PLY file"):
        read_cloud(tmp_path / "x.ply")


def test_importing_objrec3d_loads_neither_open3d_nor_opencv_nor_qt() -> None:
    import subprocess
    import sys

    code = ("import sys, objrec3d, objrec3d.kind; "
            "print(sorted(m for m in ('open3d', 'cv2', 'PySide6') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "[]"
