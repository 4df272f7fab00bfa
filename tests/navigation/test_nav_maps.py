"""The map_server loader and saver, against nav2's own test map and hand-made images."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from navigation.geometry import Pose2D
from navigation.maps import MapError, OccupancyMap, load_map, load_map_metadata, save_map


def _testmap_yaml(tmp_path: Path, shared: Path, ext: str) -> Path:
    meta = yaml.safe_load((shared / "maps/nav2_testmap/testmap.yaml").read_text())
    meta["image"] = str(shared / f"maps/nav2_testmap/testmap.{ext}")
    out = tmp_path / f"testmap_{ext}.yaml"
    out.write_text(yaml.safe_dump(meta))
    return out


@pytest.mark.realdata
@pytest.mark.parametrize("ext", ["pgm", "png", "bmp"])
def test_nav2_testmap_gives_the_expected_grid(tmp_path, shared_data, ext):
    expected = np.loadtxt(shared_data / "maps/nav2_testmap/expected_grid.txt", dtype=int)
    m = load_map(_testmap_yaml(tmp_path, shared_data, ext))
    assert m.data.shape == (10, 10)
    np.testing.assert_array_equal(m.data, expected)
    assert m.resolution == pytest.approx(0.1)
    assert (m.origin.x, m.origin.y, m.origin.yaw) == (2.0, 3.0, 1.0)


@pytest.mark.realdata
def test_nav2_testmap_yaml_as_shipped(shared_data):
    expected = np.loadtxt(shared_data / "maps/nav2_testmap/expected_grid.txt", dtype=int)
    np.testing.assert_array_equal(load_map(shared_data / "maps/nav2_testmap/testmap.yaml").data, expected)


@pytest.mark.realdata
def test_invalid_image_is_a_clear_error(shared_data):
    path = shared_data / "maps/nav2_testmap/invalid_image.yaml"
    with pytest.raises(MapError) as err:
        load_map(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}:1: image: ") and "invalid.png" in msg
    assert "not found" in msg


@pytest.mark.realdata
def test_rotated_origin_conversions(shared_data):
    m = load_map(shared_data / "maps/nav2_testmap/testmap.yaml")
    # Cell (0, 0) has its lower-left corner at the origin; its centre is half a cell along the rotated axes.
    x, y = m.cell_to_world(0, 0)
    c, s = math.cos(1.0), math.sin(1.0)
    assert (x, y) == pytest.approx((2.0 + 0.05 * c - 0.05 * s, 3.0 + 0.05 * s + 0.05 * c))
    # One cell along the grid's x axis is 0.1 m along direction yaw = 1 rad.
    x1, y1 = m.cell_to_world(1, 0)
    assert (x1 - x, y1 - y) == pytest.approx((0.1 * c, 0.1 * s))
    for i, j in [(0, 0), (3, 7), (9, 9)]:
        assert m.world_to_cell(*m.cell_to_world(i, j)) == (i, j)
    # First row of the expected grid (image bottom) is all free; the top row starts with a wall.
    assert m.value_at(*m.cell_to_world(5, 0)) == 0
    assert m.value_at(*m.cell_to_world(0, 9)) == 100
    assert m.value_at(-50.0, -50.0) == -1


def _write_image_map(tmp_path: Path, pixels: np.ndarray, name: str = "m", **fields: object) -> Path:
    cv2.imwrite(str(tmp_path / f"{name}.png"), pixels)
    meta = {"image": f"{name}.png", "resolution": 0.05, "origin": [0.0, 0.0, 0.0], "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196, **fields}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(meta))
    return path


def test_trinary_thresholds_and_row_order(tmp_path):
    # Image rows top to bottom: black, unknown grey, white, mid grey (occ 0.5 -> unknown).
    img = np.array([[0, 0], [205, 205], [254, 254], [128, 128]], dtype=np.uint8)
    m = load_map(_write_image_map(tmp_path, img))
    np.testing.assert_array_equal(m.data, [[-1, -1], [0, 0], [-1, -1], [100, 100]])


def test_negate_swaps_black_and_white(tmp_path):
    img = np.array([[0, 254]], dtype=np.uint8)
    m = load_map(_write_image_map(tmp_path, img, negate=1))
    np.testing.assert_array_equal(m.data, [[0, 100]])


def test_scale_mode_keeps_intermediate_values(tmp_path):
    # occ = 1 - v/255; with free 0.196 and occupied 0.65 a pixel of 128 (occ 0.498) scales to 66.
    img = np.array([[128, 254, 0]], dtype=np.uint8)
    m = load_map(_write_image_map(tmp_path, img, mode="scale"))
    expected = round((1 - 128 / 255 - 0.196) / (0.65 - 0.196) * 100)
    np.testing.assert_array_equal(m.data, [[expected, 0, 100]])


def test_scale_mode_transparent_pixels_are_unknown(tmp_path):
    img = np.zeros((1, 2, 4), np.uint8)
    img[0, :, :3] = 254
    img[0, 0, 3] = 255
    img[0, 1, 3] = 0
    m = load_map(_write_image_map(tmp_path, img, mode="scale"))
    np.testing.assert_array_equal(m.data, [[0, -1]])


def test_raw_mode_reads_values_directly(tmp_path):
    img = np.array([[0, 42, 100, 101, 255]], dtype=np.uint8)
    m = load_map(_write_image_map(tmp_path, img, mode="raw"))
    np.testing.assert_array_equal(m.data, [[0, 42, 100, -1, -1]])


@pytest.mark.parametrize(("fmt", "mode"), [("pgm", "trinary"), ("png", "trinary"), ("bmp", "trinary"),
                                           ("pgm", "raw"), ("png", "scale")])
def test_save_then_load_round_trip(tmp_path, fmt, mode):
    rng = np.random.default_rng(3)
    if mode == "trinary":
        data = rng.choice(np.array([0, 100, -1], np.int8), size=(17, 23))
    else:
        data = rng.integers(-1, 101, size=(17, 23)).astype(np.int8)
    original = OccupancyMap(data, 0.05, Pose2D(-1.5, 2.0, 0.3))
    path = save_map(original, tmp_path / "saved.yaml", image_format=fmt, mode=mode)
    loaded = load_map(path)
    np.testing.assert_array_equal(loaded.data, data)
    assert loaded.origin == original.origin and loaded.resolution == 0.05


def test_b5203_map_shipped_with_the_package(b5203_map, b5203_poses):
    assert (b5203_map.width, b5203_map.height) == (576, 512)  # 28.8 m x 25.6 m as the original Stage world file
    for goal in [*b5203_poses.goals, b5203_poses.station]:
        assert b5203_map.value_at(goal.x, goal.y) == 0


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        ("resolution: 0.05\norigin: [0, 0, 0]\n", "bad.yaml:1: image: missing"),
        ("image: m.png\norigin: [0, 0, 0]\n", "bad.yaml:1: resolution: missing"),
        ("image: m.png\nresolution: -1\norigin: [0, 0, 0]\n",
         "bad.yaml:2: resolution: -1 is invalid: out of range, allowed float in (0..1000]"),
        ("image: m.png\nresolution: fine\norigin: [0, 0, 0]\n",
         "bad.yaml:2: resolution: 'fine' is invalid: expected a number, got str"),
        ("image: m.png\nresolution: 0.05\norigin: [0, 0]\n",
         "bad.yaml:3: origin: [0, 0] is invalid: expected [x, y, yaw]"),
        ("image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\nmode: fancy\n",
         "bad.yaml:4: mode: 'fancy' is invalid: expected one of trinary, scale, raw"),
        ("image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 1.5\n",
         "bad.yaml:4: free_thresh: 1.5 is invalid: out of range, allowed float in 0..1"),
        ("image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n",
         "bad.yaml:4: negate: 2 is invalid: expected 0 or 1"),
        ("- just\n- a list\n", "expected a YAML mapping"),
        ("image: [unclosed\n", "not valid YAML"),
    ],
)
def test_bad_yaml_names_file_line_field_and_value(tmp_path, content, needle):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(MapError) as err:
        load_map_metadata(path)
    assert str(path) in str(err.value)
    assert needle in str(err.value)


def test_missing_yaml_and_undecodable_image(tmp_path):
    with pytest.raises(MapError, match="map file not found"):
        load_map(tmp_path / "nope.yaml")
    (tmp_path / "m.png").write_bytes(b"this is not an image")
    (tmp_path / "m.yaml").write_text("image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\n")
    with pytest.raises(MapError, match=r"m\.yaml:1: image: cannot decode .*m\.png"):
        load_map(tmp_path / "m.yaml")


def test_pgm_maxval_scales_the_samples(tmp_path):
    """A PGM with maxval 100 is white at 100 (OpenCV hands back raw samples; map_server scales them)."""
    (tmp_path / "m.pgm").write_bytes(b"P5\n# made by hand\n3 1\n100\n" + bytes([0, 50, 100]))
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    np.testing.assert_array_equal(load_map(tmp_path / "m.yaml").data, [[100, -1, 0]])
