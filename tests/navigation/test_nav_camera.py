"""The simulated RGB-D camera: pixels and depths of known scenes, noise statistics, grazing-angle dropout,
range limits, the point cloud and its transformation into the map frame."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from navigation.camera import CameraParams, RGBDCamera
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, OccupancyMap
from navigation.world import MovingObstacle, World, WorldObject

RES = 0.05
EXACT = CameraParams(noise_k=0.0, grazing_start_deg=89.9, grazing_end_deg=90.0)  # no noise, (almost) no dropout
RED = (30, 30, 200)


def room(width: float = 10.0, height: float = 8.0, origin: Pose2D | None = None) -> OccupancyMap:
    """A walled room, free inside; the inner faces of the walls are RES inside the outline."""
    w, h = round(width / RES), round(height / RES)
    data = np.full((h, w), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    return OccupancyMap(data, RES, origin or Pose2D(0.0, 0.0, 0.0))


def is_color(image: np.ndarray, color: tuple[int, int, int]) -> np.ndarray:
    """Pixels whose colour is a shade of ``color`` (same proportions, any brightness from the light)."""
    c = np.array(color, np.float64)
    img = image.astype(np.float64)
    scale = (img @ c) / (c @ c)
    return (np.abs(img - scale[..., None] * c).max(axis=-1) <= 3.0) & (scale > 0.3)


def test_intrinsics_are_the_astras():
    cam = RGBDCamera()
    fx, fy, cx, cy = cam.intrinsics()
    assert fx == pytest.approx(320.0 / math.tan(math.radians(29.0)))
    assert fy == fx and (cx, cy) == (319.5, 239.5)
    assert math.degrees(2 * math.atan(240.0 / fy)) == pytest.approx(45.15, abs=0.01)  # square pixels
    frame = cam.render(World(), room(), Pose2D(5.0, 4.0, 0.0))
    assert frame.color.shape == (480, 640, 3) and frame.color.dtype == np.uint8
    assert frame.depth.shape == (480, 640) and frame.depth.dtype == np.float32
    assert frame.points.shape == (480, 640, 3) and frame.points.dtype == np.float32
    assert np.allclose(frame.K, [[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    assert frame.camera_pose.z == 0.3
    with pytest.raises(ValueError, match="min_range < max_range"):
        CameraParams(min_range=9.0)


def test_a_cylinder_appears_at_the_projected_columns_with_the_right_depth():
    r, d = 0.2, 3.0
    world = World((WorldObject("can", "cylinder", 1.0 + d, 4.0, radius=r, height=1.0, color=RED),))
    cam = RGBDCamera(EXACT)
    frame = cam.render(world, room(), Pose2D(1.0, 4.0, 0.0))
    red = is_color(frame.color, RED)
    # Columns: the silhouette's tangent rays are at +-r / sqrt(d^2 - r^2) in normalized coordinates.
    half = cam.fx * r / math.sqrt(d * d - r * r)
    row = 240
    cols = np.nonzero(red[row])[0]
    expected_cols = np.nonzero(np.abs(np.arange(640) - cam.cx) < half)[0]
    assert cols.tolist() == expected_cols.tolist()
    assert len(cols) == 78
    # Rows: from the top rim (1.0 m high, 0.7 m above the camera) to the foot, at the nearest face (d - r).
    rows = np.nonzero(red[:, 320])[0]
    top = cam.cy + cam.fy * (0.3 - 1.0) / (d - r)
    foot = cam.cy + cam.fy * 0.3 / (d - r)
    assert rows[0] == math.ceil(top) and rows[-1] == math.floor(foot)
    assert len(rows) == rows[-1] - rows[0] + 1
    # Depth of every cylinder pixel: where the column's ray meets the circle (quadratic solved here).
    xn = (cols - cam.cx) / cam.fx
    a = 1.0 + xn * xn
    expected = (2.0 * d - np.sqrt(4.0 * d * d - 4.0 * a * (d * d - r * r))) / (2.0 * a)
    got = frame.depth[row, cols]
    assert np.all(np.abs(got - expected) <= 0.01 * expected)  # the 1 % asked for ...
    assert np.all(np.abs(got - expected) <= 1e-5 * expected)  # ... and in fact exact to float32
    assert frame.depth[240, 320] == pytest.approx(d - r, rel=1e-5)
    # With the default noise (sigma 1.2 cm at 2.8 m) the median error stays far under 1 %.
    noisy = RGBDCamera().render(world, room(), Pose2D(1.0, 4.0, 0.0))
    err = np.abs(noisy.depth[row, cols] - expected) / expected
    assert np.nanmedian(err) < 0.005
    assert np.mean(np.isfinite(noisy.depth[row, cols])) > 0.9


def test_box_and_sphere_depths():
    world = World((WorldObject("box", "box", 4.0, 3.0, yaw=0.0, width=1.0, depth=0.6, height=0.5, color=RED),
                   WorldObject("ball", "sphere", 4.0, 5.0, z=0.0, radius=0.3, color=(200, 60, 20))))
    cam = RGBDCamera(EXACT)
    frame = cam.render(world, room(), Pose2D(1.0, 3.0, 0.0))
    # The box's front face is a plane 2.7 m ahead: one depth over the whole face.
    face = is_color(frame.color, RED)
    assert face.sum() > 3000
    assert np.allclose(frame.depth[face], 2.7, rtol=1e-5)
    # Looking straight at the ball's centre (0.3 m high, level with the camera): depth = distance - radius.
    frame = cam.render(world, room(), Pose2D(1.0, 5.0, 0.0))
    assert frame.depth[240, 320] == pytest.approx(2.7, rel=1e-5)  # pixel (320, 240) is 0.5 px off the axis
    assert is_color(frame.color[240:241, 320:321], (200, 60, 20)).all()


def test_a_poster_shows_its_image_the_right_way_round():
    image = np.zeros((200, 200, 3), np.uint8)
    image[:100, :100] = (0, 0, 255)  # top left red
    image[:100, 100:] = (0, 255, 0)  # top right green
    image[100:, :100] = (255, 0, 0)  # bottom left blue
    image[100:, 100:] = (255, 255, 255)  # bottom right white
    # On the west wall (inner face x = 0.05), facing east, 1 m wide, from 0.2 m to 1.2 m high.
    poster = WorldObject("sign", "poster", 0.06, 4.0, z=0.2, yaw=0.0, width=1.0, height=1.0, image=image,
                         color=(0, 200, 200))
    world = World((poster,))
    cam = RGBDCamera(EXACT)
    frame = cam.render(world, room(), Pose2D(2.06, 4.0, math.pi))  # 2 m in front, looking at it
    # The robot looks west, so the viewer's left is south (-y): the picture's left half is at y < 4.
    uv, z = frame.project(np.array([[0.06, 3.75, 0.95], [0.06, 4.25, 0.95], [0.06, 3.75, 0.45],
                                    [0.06, 4.25, 0.45], [0.06, 4.0, 0.7]]))
    assert z == pytest.approx([2.0] * 5)
    px = [tuple(frame.color[round(v), round(u)]) for u, v in uv]
    assert uv[0, 0] < uv[1, 0] and uv[0, 1] < uv[2, 1]  # top left is left and above in the camera image
    for got, want in zip(px[:4], [(0, 0, 255), (0, 255, 0), (255, 0, 0), (255, 255, 255)], strict=True):
        assert is_color(np.array([[got]], np.uint8), want).all(), (got, want)
    # The poster's pixels have the plane's depth (2 m), also where it sits 1 cm in front of the wall.
    left, right = math.ceil(cam.cx - cam.fx * 0.5 / 2.0), math.floor(cam.cx + cam.fx * 0.5 / 2.0)
    assert np.allclose(frame.depth[240, left:right + 1], 2.0, rtol=1e-5)
    assert frame.depth[240, left - 3] == pytest.approx(2.01, rel=1e-4)  # the wall beside it
    # From behind (a poster on a stand), its back shows the poster's colour.
    stand = World((WorldObject("sign", "poster", 3.0, 4.0, z=0.2, yaw=0.0, width=1.0, height=1.0, image=image,
                               color=(0, 200, 200)),))
    back = cam.render(stand, room(), Pose2D(1.0, 4.0, 0.0))  # it faces east; the robot is west of it
    assert is_color(back.color[200:260, 300:340], (0, 200, 200)).all()


def test_walls_and_floor_are_where_the_map_puts_them():
    cam = RGBDCamera(EXACT)
    frame = cam.render(World(), room(), Pose2D(2.0, 4.0, math.pi))  # facing the west wall, face at x = 0.05
    wall_rows = np.isclose(frame.depth, 1.95, rtol=1e-5)
    assert wall_rows[:150].all()  # a flat wall square to the axis: one depth everywhere above the floor line
    # The floor line: rows below it see the floor at 0.3 / yn.
    line = cam.cy + cam.fy * 0.3 / 1.95
    v = np.arange(math.ceil(line), 480)
    yn = (v - cam.cy) / cam.fy
    assert np.allclose(frame.depth[v, 320], 0.3 / yn, rtol=1e-5)
    assert wall_rows[: math.floor(line) + 1, 320].all()
    # A low wall: its top edge is at the projected row; above it there is no return.
    low = cam.render(World(wall_height=1.0), room(), Pose2D(2.0, 4.0, math.pi))
    top = cam.cy + cam.fy * (0.3 - 1.0) / 1.95
    column = low.depth[:, 320]
    assert np.isnan(column[: math.ceil(top)]).all() and np.isfinite(column[math.ceil(top):]).all()
    # Every pixel of a frame looking into a corner lies on a wall or on the floor, within float accuracy.
    corner = cam.render(World(), room(), Pose2D(8.0, 6.0, math.radians(30)))
    pts = corner.map_points().reshape(-1, 3)
    pts = pts[np.isfinite(pts[:, 0])]
    on_floor = np.abs(pts[:, 2]) < 1e-4
    on_wall = (np.abs(pts[:, 0] - 9.95) < 1e-4) | (np.abs(pts[:, 1] - 7.95) < 1e-4)
    assert np.all(on_floor | on_wall)
    assert on_floor.sum() > 10000 and on_wall.sum() > 50000


def test_walls_follow_a_rotated_map_origin():
    data = np.full((80, 100), FREE, np.int8)
    data[:, -1] = OCCUPIED
    m = OccupancyMap(data, RES, Pose2D(1.0, 1.0, math.pi / 2))  # grid x runs along world +y
    frame = RGBDCamera(EXACT).render(None, m, Pose2D(0.0, 2.0, math.pi / 2))
    # The wall's face (grid column 99) is at world y = 1 + 99 * 0.05 = 5.95; the camera looks along +y.
    assert frame.depth[100, 320] == pytest.approx(3.95, rel=1e-5)


def test_walls_can_come_from_the_simulations_obstacle_field():
    occ = room()
    data = occ.data.copy()
    data[76:84, 60:64] = OCCUPIED  # a pillar at x 3.0-3.2, y 3.8-4.2 that only the field knows
    field = ObstacleField(OccupancyMap(data, RES, occ.origin))
    cam = RGBDCamera(replace(EXACT, max_range=20.0))
    assert cam.render(None, field, Pose2D(1.0, 4.0, 0.0)).depth[200, 320] == pytest.approx(2.0, rel=1e-5)
    assert cam.render(None, occ, Pose2D(1.0, 4.0, 0.0)).depth[200, 320] == pytest.approx(8.95, rel=1e-5)


def test_depth_noise_grows_with_the_square_of_the_distance():
    cam = RGBDCamera(CameraParams(), random_seed=7)
    truth_cam = RGBDCamera(EXACT)
    for distance in (1.5, 4.0):
        pose = Pose2D(0.05 + distance, 4.0, math.pi)  # square to the west wall
        truth = truth_cam.render(World(), room(), pose).depth[:200, 200:440]
        assert np.allclose(truth, distance, rtol=1e-5)
        errors = np.concatenate([(cam.render(World(), room(), pose).depth[:200, 200:440] - truth).ravel()
                                 for _ in range(3)])
        sigma = 0.0015 * distance ** 2
        assert np.isfinite(errors).all()  # square-on: no dropout
        assert np.std(errors) == pytest.approx(sigma, rel=0.03)
        assert abs(np.mean(errors)) < 0.01 * sigma
    # Frames differ in their noise, and the same seed repeats the same frames.
    a, b = (RGBDCamera(random_seed=3).render(World(), room(), Pose2D(2.0, 4.0, math.pi)) for _ in range(2))
    assert np.array_equal(a.depth, b.depth, equal_nan=True)
    again = RGBDCamera(random_seed=3)
    first, second = (again.render(World(), room(), Pose2D(2.0, 4.0, math.pi)) for _ in range(2))
    assert np.array_equal(first.depth, a.depth, equal_nan=True)
    assert not np.array_equal(first.depth, second.depth, equal_nan=True)
    other = RGBDCamera(random_seed=4).render(World(), room(), Pose2D(2.0, 4.0, math.pi))
    assert not np.array_equal(other.depth, a.depth, equal_nan=True)


def test_returns_go_missing_at_grazing_angles():
    cam = RGBDCamera(CameraParams(noise_k=0.0, max_range=30.0), random_seed=1)  # no range cut on the floor
    frames = [cam.render(World(), room(20.0, 8.0), Pose2D(1.0, 4.0, 0.0)) for _ in range(4)]
    yn = (np.arange(480) - cam.cy) / cam.fy
    missing = np.mean([np.isnan(f.depth[:, 300:340]).mean(axis=1) for f in frames], axis=0)  # per row
    # Floor rows: the angle between the ray and the floor's normal is atan(1 / yn) near the centre column.
    angle = np.degrees(np.arctan2(1.0, yn))
    floor_rows = (yn > 0) & (0.3 / np.maximum(yn, 1e-9) < 18.9)  # the floor in front of the east wall
    assert missing[floor_rows & (angle < 79.5)].max() == 0.0
    assert missing[floor_rows & (angle > 88.0)].min() > 0.85
    mid = floor_rows & (angle > 84.0) & (angle < 85.0)
    assert 0.35 < missing[mid].mean() < 0.65  # about half way between 80 and 89 degrees
    # A wall seen square-on loses nothing; seen along it (looking down a corridor side) it loses returns.
    assert np.isfinite(frames[0].depth[195:235, 300:340]).all()  # the east wall, 18 m away
    side = cam.render(World(), room(10.0, 1.0), Pose2D(1.0, 0.5, 0.0))  # a corridor 0.9 m wide, 8.95 m long
    xn = np.abs(np.arange(640) - cam.cx) / cam.fx
    lost = np.isnan(side.depth[236:244]).mean(axis=0)  # rows at the camera's height
    on_side = 0.45 / np.maximum(xn, 1e-9) < 8.9  # columns that see a side wall before the end wall
    angle = np.degrees(np.arccos(xn / np.sqrt(1.0 + xn * xn)))  # between the ray and the side wall's normal
    assert lost[on_side & (angle < 79.5)].max() == 0.0
    assert lost[on_side & (angle > 86.0)].mean() > 0.6
    assert lost[~on_side].max() == 0.0  # the end wall, square on


def test_an_object_behind_the_robot_is_not_seen():
    world = World((WorldObject("can", "cylinder", 3.0, 4.0, radius=0.2, height=1.0, color=RED),))
    cam = RGBDCamera(EXACT)
    behind = cam.render(world, room(), Pose2D(5.0, 4.0, 0.0))  # the can is 2 m behind
    empty = cam.render(World(), room(), Pose2D(5.0, 4.0, 0.0))
    assert not is_color(behind.color, RED).any()
    assert np.array_equal(behind.depth, empty.depth, equal_nan=True)
    assert np.array_equal(behind.color, empty.color)
    ahead = cam.render(world, room(), Pose2D(5.0, 4.0, math.pi))
    assert is_color(ahead.color, RED).sum() > 5000
    # Right beside the camera (outside the field of view, partly behind the optical centre) it is not drawn.
    beside = cam.render(World((WorldObject("can", "cylinder", 5.0, 3.0, radius=0.2, height=1.0, color=RED),)),
                        room(), Pose2D(5.0, 4.0, 0.0))
    assert not is_color(beside.color, RED).any()


def test_range_limits_and_near_objects():
    box = WorldObject("box", "box", 5.45, 4.0, width=1.0, depth=0.1, height=1.0, color=RED)  # face 0.4 m ahead
    frame = RGBDCamera(EXACT).render(World((box,)), room(), Pose2D(5.0, 4.0, 0.0))
    face = is_color(frame.color, RED)
    assert face[240, 320] and face.sum() > 100000  # drawn in colour ...
    assert np.isnan(frame.depth[face]).all()  # ... but nearer than 0.6 m: no depth
    assert np.isnan(frame.points[face]).all()
    far = RGBDCamera(EXACT).render(World(), room(20.0, 8.0), Pose2D(1.0, 4.0, 0.0))  # the east wall 18.95 m away
    assert np.isnan(far.depth[195:245, 300:340]).all()  # between the wall's top edge and the floor line
    assert (far.color[195:245, 300:340] != 235).any(axis=-1).all()  # the wall is still in the colour image


def test_nearer_objects_hide_farther_ones():
    near = WorldObject("near", "box", 3.0, 4.0, width=0.6, depth=0.2, height=0.5, color=RED)
    far = WorldObject("far", "cylinder", 5.0, 4.0, radius=0.5, height=1.5, color=(200, 60, 20))
    frame = RGBDCamera(EXACT).render(World((far, near)), room(), Pose2D(1.0, 4.0, 0.0))
    assert is_color(frame.color[240:241, 320:321], RED).all()
    assert frame.depth[240, 320] == pytest.approx(1.9, rel=1e-5)
    # Above the low box the taller cylinder behind it shows, at its own depth.
    assert is_color(frame.color[100:101, 320:321], (200, 60, 20)).all()
    assert frame.depth[100, 320] == pytest.approx(3.5, rel=1e-4)


def test_moving_obstacles_are_drawn_where_they_are():
    walker = MovingObstacle(WorldObject("w", "cylinder", 4.0, 1.0, radius=0.25, height=1.7, color=RED),
                            (4.0, 1.0), (4.0, 7.0), 1.0)
    world = World((), (walker,))
    cam = RGBDCamera(EXACT)
    assert not is_color(cam.render(world, room(), Pose2D(1.0, 4.0, 0.0), t=0.0).color, RED).any()
    frame = cam.render(world, room(), Pose2D(1.0, 4.0, 0.0), t=3.0)  # now straight ahead
    assert frame.depth[240, 320] == pytest.approx(2.75, rel=1e-4)


def test_points_are_the_depth_rays_and_map_back_onto_the_scene():
    world = World((WorldObject("can", "cylinder", 4.0, 3.5, radius=0.2, height=1.0, color=RED),))
    cam = RGBDCamera()  # with noise: the points are where the noisy depth puts them
    frame = cam.render(world, room(), Pose2D(1.0, 3.0, 0.2))
    z = frame.depth
    assert np.array_equal(frame.points[..., 2], z, equal_nan=True)
    assert np.allclose(frame.points[..., 0], (np.arange(640) - frame.cx) / frame.fx * z, equal_nan=True)
    assert np.allclose(frame.points[..., 1], (np.arange(480)[:, None] - frame.cy) / frame.fy * z, equal_nan=True)
    red = is_color(frame.color, RED) & np.isfinite(z)
    pts = frame.camera_to_map(frame.points[red])
    assert pts.shape == (red.sum(), 3)
    radial = np.hypot(pts[:, 0] - 4.0, pts[:, 1] - 3.5)
    assert np.median(np.abs(radial - 0.2)) < 0.01  # on the cylinder's surface, up to the depth noise
    assert pts[:, 2].min() > -0.03 and pts[:, 2].max() < 1.03
    # project() inverts camera_to_map, and pixel rays point at what the pixel sees.
    uv, depth = frame.project(pts[:5])
    rows, cols = np.nonzero(red)
    assert uv == pytest.approx(np.column_stack([cols[:5], rows[:5]]), abs=1e-3)
    assert depth == pytest.approx(z[rows[:5], cols[:5]], rel=1e-5)
    origin, direction = frame.pixel_ray(cols[0], rows[0])
    assert origin == pytest.approx([frame.camera_pose.x, frame.camera_pose.y, 0.3])
    assert np.cross(direction, pts[0] - origin) == pytest.approx(np.zeros(3), abs=1e-4)
    assert frame.pixel_rays(np.array([[cols[0], rows[0]]]))[0] == pytest.approx(direction)
    floor = frame.map_points()[470]
    assert np.nanmax(np.abs(floor[:, 2])) < 0.01  # the bottom row sees the floor


def test_the_mount_moves_and_turns_the_camera():
    params = CameraParams(mount_x=0.1, mount_y=-0.05, mount_z=0.5, mount_yaw=math.pi / 2, noise_k=0.0,
                          grazing_start_deg=89.9, grazing_end_deg=90.0)
    cam = RGBDCamera(params)
    pose = cam.camera_pose(Pose2D(2.0, 3.0, math.pi / 2))
    assert (pose.x, pose.y, pose.z, pose.yaw) == pytest.approx((2.05, 3.1, 0.5, math.pi))
    frame = cam.render(World(), room(), Pose2D(2.0, 3.0, math.pi / 2))
    assert frame.depth[100, 320] == pytest.approx(2.05 - 0.05, rel=1e-5)  # looking west at the wall
    yn = (479 - cam.cy) / cam.fy
    assert frame.depth[479, 320] == pytest.approx(0.5 / yn, rel=1e-5)  # the floor seen from 0.5 m
