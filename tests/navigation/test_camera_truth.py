"""The simulated camera's ground truth: the objects a frame shows, in the optical frame, with their pixels and
visible points, checked against the frame's own pixels and point cloud."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from navigation.camera import CameraParams, RGBDCamera, RGBDFrame
from navigation.geometry import Pose2D
from navigation.world import MovingObstacle, World, WorldObject
from tests.navigation.test_nav_camera import EXACT, RED, is_color, room

BLUE = (200, 60, 20)


def test_a_cylinder_s_truth_matches_what_the_camera_drew():
    r, d = 0.2, 3.0
    world = World((WorldObject("can", "cylinder", 1.0 + d, 4.0, radius=r, height=1.0, color=RED),))
    frame = RGBDCamera(EXACT).render(world, room(), Pose2D(1.0, 4.0, 0.0))
    [can] = frame.truth()
    assert (can.name, can.shape, can.radius, can.height, can.obstacle) == ("can", "cylinder", 0.2, 1.0, False)
    # Optical frame: x right, y down, z forward; the centre is 0.2 m above the camera (0.5 m against 0.3 m).
    assert can.centre == pytest.approx((0.0, -0.2, 3.0), abs=1e-12)
    # Upright, pointing toward the sensor (which is below the centre): down the image.
    assert can.axis == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    assert can.size is None and can.distance == pytest.approx(math.hypot(0.2, 3.0))
    red = is_color(frame.color, RED)
    assert can.pixels == red.sum()  # every red pixel and nothing else
    assert can.visible_points == int(np.isfinite(frame.depth[red]).sum())
    vs, us = np.nonzero(red)
    assert can.box_px == (us.min(), vs.min(), us.max() + 1, vs.max() + 1)
    assert can.box_px[2] - can.box_px[0] == 78  # the silhouette's 78 columns (test_nav_camera)


def test_a_sphere_s_visible_points_lie_on_the_sphere_of_its_truth():
    world = World((WorldObject("ball", "sphere", 3.0, 4.5, z=0.2, radius=0.15, color=BLUE),))
    frame = RGBDCamera(EXACT).render(world, room(), Pose2D(1.0, 4.0, 0.3))
    [ball] = frame.truth()
    assert ball.shape == "sphere" and ball.radius == 0.15 and ball.axis is None and ball.height == 0.0
    expected = frame.map_to_camera(np.array([3.0, 4.5, 0.35]))
    assert ball.centre == pytest.approx(tuple(expected), abs=1e-12)
    points = frame.points[frame.object_ids == 0]
    points = points[np.isfinite(points).all(axis=1)]
    assert len(points) == ball.visible_points > 3000
    gaps = np.linalg.norm(points - np.array(ball.centre), axis=1) - ball.radius
    assert np.abs(gaps).max() < 1e-4  # float32 depth of an exact camera


def test_a_box_and_a_poster_have_size_and_orientation_in_the_optical_frame():
    yaw = 0.3
    world = World((WorldObject("crate", "box", 4.0, 3.5, yaw=yaw, width=0.4, depth=0.3, height=0.5, color=RED),
                   WorldObject("sign", "poster", 4.0, 5.0, z=0.4, yaw=math.pi, width=0.6, height=0.4)))
    frame = RGBDCamera(EXACT).render(world, room(), Pose2D(1.0, 4.0, 0.0))
    crate, sign = frame.truth()
    # Camera looking along +x: optical x = -map y, y = -map z, z = map x (relative to the camera).
    assert crate.centre == pytest.approx((0.5, 0.3 - 0.25, 3.0), abs=1e-12)
    assert crate.size == (0.3, 0.4, 0.5)  # along its heading, across it, up
    rotation = crate.rotation
    assert rotation[:, 0] == pytest.approx([-math.sin(yaw), 0.0, math.cos(yaw)], abs=1e-12)  # its heading
    assert rotation[:, 1] == pytest.approx([-math.cos(yaw), 0.0, -math.sin(yaw)], abs=1e-12)  # across it
    assert rotation[:, 2] == pytest.approx([0.0, -1.0, 0.0], abs=1e-12)  # up
    assert np.allclose(rotation.T @ rotation, np.eye(3)) and np.linalg.det(rotation) == pytest.approx(1.0)
    assert (crate.shape, crate.source_shape, sign.shape, sign.source_shape) == ("box", "box", "box", "poster")
    assert sign.size == (0.02, 0.6, 0.4)  # the board's thickness, its width and height
    assert sign.centre == pytest.approx((-1.0, 0.3 - 0.6, 3.0), abs=1e-12)
    assert sign.rotation[:, 0] == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)  # it faces the camera
    data = json.loads(json.dumps([crate.as_dict(), sign.as_dict(extras=True)]))
    assert set(data[0]) == {"name", "shape", "centre", "size", "orientation", "visible_points"}
    assert data[1]["size"] == [0.02, 0.6, 0.4] and data[1]["source_shape"] == "poster"
    assert data[1]["pixels"] == sign.pixels > 0 and data[1]["box_px"] == list(sign.box_px)


def test_the_plain_truth_reads_as_the_point_cloud_kind_s_truth_shapes():
    truth3d = pytest.importorskip("objrec3d.truth")
    world = World((WorldObject("crate", "box", 4.0, 3.5, yaw=0.3, width=0.4, depth=0.3, height=0.5),
                   WorldObject("can", "cylinder", 4.0, 4.6, radius=0.1, height=0.4),
                   WorldObject("ball", "sphere", 4.0, 5.2, radius=0.1)))
    seen = RGBDCamera(EXACT).render(world, room(), Pose2D(1.0, 4.0, 0.3)).truth()
    shapes = [truth3d.as_truth_shape(s.as_dict()) for s in seen]
    assert [(t.name, t.shape) for t in shapes] == [("crate", "box"), ("can", "cylinder"), ("ball", "sphere")]
    for s, t in zip(seen, shapes, strict=True):
        assert t.centre == s.centre and t.visible_points == s.visible_points > 0
    assert np.allclose(shapes[0].rotation(), seen[0].rotation) and shapes[0].size == (0.3, 0.4, 0.5)
    assert shapes[1].axis == seen[1].axis and (shapes[1].radius, shapes[1].height) == (0.1, 0.4)


def test_hidden_behind_the_camera_or_out_of_range():
    world = World((WorldObject("near", "cylinder", 3.0, 4.0, radius=0.1, height=0.4, color=RED),
                   WorldObject("hidden", "cylinder", 5.0, 4.0, radius=0.1, height=0.3, color=BLUE),
                   WorldObject("behind", "cylinder", 0.5, 4.0, radius=0.1, height=0.4),
                   WorldObject("far", "cylinder", 9.5, 3.0, radius=0.2, height=1.0)))
    camera = RGBDCamera(EXACT)
    frame = camera.render(world, room(), Pose2D(1.0, 4.0, 0.0))
    seen = {s.name: s for s in frame.truth()}
    assert set(seen) == {"near", "far"}  # "hidden" stands right behind "near", "behind" behind the camera
    assert seen["near"].visible_points == seen["near"].pixels > 1000
    assert seen["far"].pixels > 500 and seen["far"].visible_points == 0  # 8.5 m: beyond the 8 m range
    # A partly hidden object: shown, with fewer pixels than alone.
    shifted = World((world.objects[0], world.objects[1].shifted(0.0, 0.12)))
    both = {s.name: s for s in camera.render(shifted, room(), Pose2D(1.0, 4.0, 0.0)).truth()}
    alone = camera.render(World((shifted.objects[1],)), room(), Pose2D(1.0, 4.0, 0.0)).truth()[0]
    assert 0 < both["hidden"].pixels < alone.pixels


def test_obstacles_only_when_asked_and_where_they_are_at_the_frame_s_time():
    walker = MovingObstacle(WorldObject("walker", "cylinder", 3.0, 3.0, radius=0.2, height=1.7), (3.0, 3.0),
                            (3.0, 5.0), 1.0)
    world = World((WorldObject("can", "cylinder", 5.0, 4.0, radius=0.1, height=0.4, color=RED),), (walker,))
    camera = RGBDCamera(EXACT)
    frame = camera.render(world, room(), Pose2D(1.0, 4.0, 0.0), t=1.0)  # the walker in front of the can
    assert frame.truth() == []  # the can is fully hidden
    [walking] = frame.truth(obstacles=True)
    assert walking.obstacle and walking.centre[0] == pytest.approx(0.0, abs=1e-12)  # at (3, 4): straight ahead
    later = camera.render(world, room(), Pose2D(1.0, 4.0, 0.0), t=0.0).truth(obstacles=True)
    assert [s.name for s in later] == ["can", "walker"]
    assert later[1].centre[0] == pytest.approx(1.0, abs=1e-12)  # at (3, 3): 1 m to the right


def test_noise_and_dropout_leave_the_truth_but_cost_visible_points():
    world = World((WorldObject("can", "cylinder", 3.0, 4.0, radius=0.4, height=1.0, color=RED),))
    exact = RGBDCamera(EXACT).render(world, room(), Pose2D(1.0, 4.0, 0.0)).truth()[0]
    noisy = RGBDCamera(CameraParams(), random_seed=3).render(world, room(), Pose2D(1.0, 4.0, 0.0)).truth()[0]
    assert noisy.centre == exact.centre and noisy.pixels == exact.pixels
    assert exact.visible_points == exact.pixels == 80636
    # Returns lost where the sides turn away beyond 80 degrees from the ray (the outer 1.5 % of the radius).
    assert 0.002 < 1.0 - noisy.visible_points / exact.visible_points < 0.02


def test_a_frame_made_by_hand_shows_nothing():
    frame = RGBDCamera(EXACT).render(World(), room(), Pose2D(1.0, 4.0, 0.0))
    assert frame.truth() == []
    bare = RGBDFrame(frame.color, frame.depth, frame.fx, frame.fy, frame.cx, frame.cy, frame.points,
                     frame.camera_pose, frame.robot_pose)
    assert bare.truth() == [] and bare.object_ids is None
