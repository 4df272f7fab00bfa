"""MapView: the one crop-scale-and-convert of a map picture, shared by the run picture and the inspection picture."""

from __future__ import annotations

import numpy as np

from navigation.geometry import Pose2D
from navigation.map_view import MapView
from navigation.maps import OccupancyMap


def _room(size: int, resolution: float = 0.05) -> OccupancyMap:
    """Free cells with an occupied wall round a square of ``size`` cells, unknown outside it (10 cells each side)."""
    data = np.full((size + 20, size + 20), -1, np.int8)
    data[10:10 + size, 10:10 + size] = 0
    data[10, 10:10 + size] = data[9 + size, 10:10 + size] = 100
    data[10:10 + size, 10] = data[10:10 + size, 9 + size] = 100
    return OccupancyMap(data, resolution, Pose2D(-1.0, -2.0, 0.0))


def test_the_known_part_is_cropped_with_its_margin_and_scaled_up_by_a_whole_factor() -> None:
    view = MapView.of_known(_room(100), 1000)
    assert (view.c0, view.c1, view.r0, view.r1) == (6, 114, 6, 114)  # 100 known cells and 4 around
    assert view.scale == 9  # 1000 // 108
    assert view.image.shape == (108 * 9, 108 * 9, 3)
    assert view.px_per_m == 9 / 0.05


def test_a_map_larger_than_the_picture_is_scaled_down_not_drawn_a_cell_per_pixel() -> None:
    view = MapView.of_known(_room(3000), 1000)
    assert max(view.image.shape[:2]) == 1000  # 3,008 cells across
    assert 0.33 < view.scale < 0.34


def test_a_world_point_lands_on_its_cell() -> None:
    occ_map = _room(100)
    view = MapView.of_known(occ_map, 1000)
    x, y = occ_map.cell_to_world(10, 50)  # the wall's cell: column 10, row 50 (row 0 at the bottom)
    px, py = view.px(x, y)
    assert tuple(view.image[py, px]) == (0, 0, 0)  # occupied is black
    fx, fy = occ_map.cell_to_world(50, 50)
    assert tuple(view.image[view.px(fx, fy)[::-1]]) == (254, 254, 254)  # free
    many = view.px_array(np.array([[x, y], [fx, fy]]))
    assert many.tolist() == [list(view.px(x, y)), list(view.px(fx, fy))]


def test_a_heading_mark_points_along_the_pose() -> None:
    view = MapView.of_known(_room(100), 1000)
    start = view.px(0.0, 0.0)
    tip = view.heading(Pose2D(0.0, 0.0, 0.0), 0.5)  # +x in the world is to the right in the picture
    assert tip[1] == start[1] and tip[0] - start[0] == round(0.5 * view.px_per_m)
    up = view.heading(Pose2D(0.0, 0.0, np.pi / 2), 0.5)  # +y is up: smaller rows
    assert up[0] == start[0] and start[1] - up[1] == round(0.5 * view.px_per_m)


def test_zones_are_tinted_over_their_cells_only() -> None:
    occ_map = _room(100)
    view = MapView.of_known(occ_map, 1000)
    zones = np.zeros((occ_map.height, occ_map.width, 4), np.uint8)
    zones[40:60, 40:60] = (0, 0, 255, 160)
    before = view.image.copy()
    view.tint(zones)
    inside = view.px(*occ_map.cell_to_world(50, 50))
    outside = view.px(*occ_map.cell_to_world(80, 80))
    assert view.image[inside[1], inside[0], 2] > view.image[inside[1], inside[0], 0]  # reddened
    assert np.array_equal(view.image[outside[1], outside[0]], before[outside[1], outside[0]])
