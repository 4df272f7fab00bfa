"""Bounded navigation readers: a map costs its int8 grid, not float64 copies of its image, with exactly
the occupancy map_server gives; a microscopic resolution is refused naming the file; posters are bounded and kept
small; a start pose inside a world object names it."""

from __future__ import annotations

import resource
from pathlib import Path

import cv2
import numpy as np
import pytest

from navigation.geometry import Pose2D
from navigation.maps import MapError, MapMetadata, load_map, occupancy_from_pixels
from navigation.world import POSTER_SIDE, World, WorldError, WorldObject, parse_world


def float_occupancy(pixels: np.ndarray, meta: MapMetadata, max_value: float) -> np.ndarray:
    """map_server's formula, as the reader computed it before the table: the reference."""
    img = pixels.astype(np.float64)
    alpha = None
    if img.ndim == 2:
        channels = [img] * 3
    elif img.shape[2] <= 2:
        channels = [img[:, :, 0]] * 3
        alpha = img[:, :, 1] if img.shape[2] == 2 else None
    else:
        channels = [img[:, :, k] for k in range(3)]
        alpha = img[:, :, 3] if img.shape[2] == 4 else None
    if meta.mode == "trinary" and alpha is not None:
        channels = [*channels, alpha]
    shade = sum(channels) / (len(channels) * max_value)
    occ = shade if meta.negate else 1.0 - shade
    out = np.full(shade.shape, -1, dtype=np.int8)
    if meta.mode == "raw":
        percent = np.floor(shade * 255.0 + 0.5)
        ok = (percent >= 0) & (percent <= 100)
        out[ok] = percent[ok].astype(np.int8)
        return out
    occupied = meta.occupied_thresh < occ
    free = occ < meta.free_thresh
    out[occupied] = 100
    out[free & ~occupied] = 0
    if meta.mode == "scale":
        middle = ~occupied & ~free
        span = meta.occupied_thresh - meta.free_thresh
        if span > 0:
            scaled = np.rint((occ - meta.free_thresh) / span * 100.0)
            out[middle] = np.clip(scaled[middle], 0, 100).astype(np.int8)
        if alpha is not None:
            out[alpha < max_value] = -1
    return out


@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [False, True])
@pytest.mark.parametrize(("shape", "dtype", "max_value"), [
    ((60, 70), np.uint8, 255.0), ((60, 70), np.uint16, 65535.0), ((60, 70), np.uint16, 1000.0),
    ((60, 70, 2), np.uint8, 255.0), ((60, 70, 3), np.uint8, 255.0), ((60, 70, 4), np.uint8, 255.0),
    ((60, 70, 4), np.uint16, 65535.0)])
def test_the_table_gives_exactly_map_servers_occupancy(mode, negate, shape, dtype, max_value):
    rng = np.random.default_rng(7)
    pixels = rng.integers(0, int(max_value) + 1, shape).astype(dtype)
    if len(shape) == 3 and shape[2] in (2, 4):
        pixels[..., -1][rng.random(shape[:2]) < 0.5] = int(max_value)  # half opaque
    meta = MapMetadata(Path("m.pgm"), 0.05, Pose2D(0, 0, 0), negate, 0.65, 0.196, mode)
    np.testing.assert_array_equal(occupancy_from_pixels(pixels, meta, max_value),
                                  float_occupancy(pixels, meta, max_value))


def test_a_map_of_25_million_cells_loads_in_little_memory(tmp_path, monkeypatch):
    """The reader's own cost, with the cell limit raised as a user with a huge map would (the default limit,
    4 M cells, is what the patrol's planner can hold in 500 MB)."""
    monkeypatch.setenv("OBJREC_MAX_MAP_CELLS", "25_000_000")
    cv2.imwrite(str(tmp_path / "big.pgm"), np.full((5000, 5000), 254, np.uint8))
    (tmp_path / "big.yaml").write_text("image: big.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    grid = load_map(tmp_path / "big.yaml")
    grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    assert grid.data.shape == (5000, 5000) and int(grid.data.max()) == 0
    assert grown_mb < 300, f"{grown_mb:.0f} MB more"  # float64 copies of the image took 700 MB


def test_a_microscopic_resolution_names_the_file(tmp_path):
    cv2.imwrite(str(tmp_path / "m.pgm"), np.full((10, 10), 254, np.uint8))
    (tmp_path / "tiny.yaml").write_text("image: m.pgm\nresolution: 1.0e-300\norigin: [0, 0, 0]\n")
    with pytest.raises(MapError, match=r"tiny.yaml:2: resolution: 1e-300 is invalid: cells finer than 0.0001 m"):
        load_map(tmp_path / "tiny.yaml")


def test_a_map_yaml_over_64_kib_is_refused(tmp_path):
    cv2.imwrite(str(tmp_path / "m.pgm"), np.full((10, 10), 254, np.uint8))
    (tmp_path / "big.yaml").write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnotes: ["
                                       + ",".join("1" for _ in range(40_000)) + "]\n")
    with pytest.raises(MapError, match=r"big\.yaml: is 80,057 bytes, over the limit of 65,536 bytes"):
        load_map(tmp_path / "big.yaml")


def test_posters_are_bounded_before_reading_and_kept_small(tmp_path, monkeypatch):
    cv2.imwrite(str(tmp_path / "wide.png"), np.full((300, 3000, 3), 90, np.uint8))
    world = parse_world("objects: [{name: p, shape: poster, x: 1, y: 1, width: 1, height: 1, image: wide.png}]",
                        tmp_path / "w.yaml")
    assert world.objects[0].image.shape == (POSTER_SIDE // 10, POSTER_SIDE, 3)
    monkeypatch.setenv("OBJREC_MAX_POSTER_PIXELS", "100000")
    with pytest.raises(WorldError, match=r"w.yaml:1: objects\[0\].image: .*poster of 3000x300: 900,000 pixels, "
                                         r"over the limit of 100,000 pixels \(set OBJREC_MAX_POSTER_PIXELS"):
        parse_world("objects: [{name: p, shape: poster, x: 1, y: 1, width: 1, height: 1, image: wide.png}]",
                    tmp_path / "w.yaml")


def test_what_stands_on_a_pose_is_named():
    world = World((WorldObject("crate", "box", 2.0, 2.0, width=0.5, depth=0.5, height=0.5),
                   WorldObject("ball", "sphere", 5.0, 5.0, radius=0.2)))
    assert world.colliding(2.1, 2.0, 0.18) == ["crate"]
    assert world.colliding(9.0, 9.0, 0.18) == []
