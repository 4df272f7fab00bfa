"""The world file: loading and its errors, modified copies, footprints, collisions, rays, and the simulator
colliding with and scanning the world's objects and obstacles."""

from __future__ import annotations

import math
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, OccupancyMap
from navigation.simulation import Simulation, StartPoseError
from navigation.world import (
    POSTER_THICKNESS,
    MovingObstacle,
    World,
    WorldError,
    WorldObject,
    load_world,
    objects_near,
    parse_world,
)

RES = 0.05

WORLD = """\
map: lab.yaml
walls: {height: 2.5, color: [200, 201, 202]}
floor: {color: [100, 101, 102]}
objects:
  - name: red_can
    shape: cylinder
    x: 2.0
    y: 1.5
    radius: 0.06
    height: 0.25
    color: [30, 30, 200]
  - {name: crate, shape: box, x: 3.0, y: 1.0, yaw: 0.3, width: 0.4, depth: 0.3, height: 0.3}
  - {name: ball, shape: sphere, x: 1.0, y: 3.0, z: 0.4, radius: 0.1, color: [200, 60, 20]}
  - {name: sign, shape: poster, x: 0.06, y: 2.0, z: 0.5, width: 0.6, height: 0.4, image: sign.png}
obstacles:
  - {name: bin, shape: box, x: 4.0, y: 2.5, width: 0.4, depth: 0.5, height: 0.6}
  - {name: walker, shape: cylinder, radius: 0.25, height: 1.7, path: [[1, 1], [4, 1]], speed: 0.5}
"""


def room(width: float = 6.0, height: float = 4.0) -> OccupancyMap:
    w, h = round(width / RES), round(height / RES)
    data = np.full((h, w), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    return OccupancyMap(data, RES, Pose2D(0.0, 0.0, 0.0))


@pytest.fixture
def world_file(tmp_path: Path) -> Path:
    image = np.zeros((40, 60, 3), np.uint8)
    image[:, :30] = (0, 0, 255)
    cv2.imwrite(str(tmp_path / "sign.png"), image)
    path = tmp_path / "lab.world.yaml"
    path.write_text(WORLD, encoding="utf-8")
    return path


def test_a_world_file_loads_every_shape_and_the_obstacles(world_file: Path):
    world = load_world(world_file)
    assert world.names == ["red_can", "crate", "ball", "sign", "bin", "walker"]
    assert world.map_path == world_file.parent / "lab.yaml"
    assert (world.wall_height, world.wall_color, world.floor_color) == (2.5, (200, 201, 202), (100, 101, 102))
    can, crate, ball, sign = world.objects
    assert (can.shape, can.x, can.y, can.z, can.radius, can.height, can.color) == (
        "cylinder", 2.0, 1.5, 0.0, 0.06, 0.25, (30, 30, 200))
    assert (crate.shape, crate.yaw, crate.width, crate.depth, crate.height) == ("box", 0.3, 0.4, 0.3, 0.3)
    assert crate.color == (128, 128, 128)  # the default
    assert (ball.z, ball.top, ball.centre) == (0.4, pytest.approx(0.6), pytest.approx((1.0, 3.0, 0.5)))
    assert sign.image_path == world_file.parent / "sign.png"
    assert sign.image is not None and sign.image.shape == (40, 60, 3)
    assert tuple(sign.image[0, 0]) == (0, 0, 255) and tuple(sign.image[0, 59]) == (0, 0, 0)
    bin_, walker = world.obstacles
    assert isinstance(bin_, WorldObject) and (bin_.depth, bin_.width) == (0.5, 0.4)
    assert isinstance(walker, MovingObstacle)
    assert (walker.start, walker.end, walker.speed, walker.length) == ((1.0, 1.0), (4.0, 1.0), 0.5, 3.0)
    assert walker.body.yaw == 0.0  # faces along its path


def test_a_moving_obstacle_goes_back_and_forth():
    walker = MovingObstacle(WorldObject("w", "cylinder", 1.0, 1.0, radius=0.2, height=1.0), (1.0, 1.0),
                            (4.0, 1.0), 0.5)
    assert walker.position_at(0.0) == (1.0, 1.0)
    assert walker.position_at(2.0) == pytest.approx((2.0, 1.0))
    assert walker.position_at(6.0) == pytest.approx((4.0, 1.0))  # the far end after 3 m at 0.5 m/s
    assert walker.position_at(8.0) == pytest.approx((3.0, 1.0))  # on its way back
    assert walker.position_at(12.0) == pytest.approx((1.0, 1.0))
    assert walker.position_at(12.0 * 5 + 2.0) == pytest.approx((2.0, 1.0))  # periodic
    assert walker.at(8.0).x == pytest.approx(3.0) and walker.at(8.0).radius == 0.2


@pytest.mark.parametrize(("text", "message"), [
    ("objects: [{shape: box, x: 1, y: 1, width: 1, depth: 1, height: 1}]",
     r"bad.world.yaml:1: objects\[0\].name: missing"),
    ("objects:\n  - {name: a, shape: cone, x: 1, y: 1}",
     r"bad.world.yaml:2: objects\[0\].shape: 'cone' is invalid: one of cylinder, box, sphere, poster"),
    ("objects:\n  - name: a\n    shape: cylinder\n    x: 1\n    y: 1\n    radius: -0.1\n    height: 1",
     r"bad.world.yaml:6: objects\[0\].radius: -0.1 is invalid: out of range, allowed float in \(0\.\.1000\]"),
    ("objects:\n  - {name: a, shape: cylinder, x: 1, y: 1, height: 1}",
     r"bad.world.yaml:2: objects\[0\].radius: missing \(size in metres\)"),
    ("objects:\n  - {name: a, shape: sphere, x: 1, y: 1, radius: 0.1, color: [0, 0, 300]}",
     r":2: objects\[0\].color\[2\]: 300 is invalid: out of range, allowed int in 0..255"),
    ("objects:\n  - {name: a, shape: sphere, x: 1, y: 1, radius: 0.1, colour: [0, 0, 0]}",
     r":2: objects\[0\].colour: unknown key \(allowed: name, shape, x, y, z, yaw, color, radius\)"),
    ("objects:\n  - {name: a, shape: sphere, x: 1, y: one, radius: 0.1}",
     r":2: objects\[0\].y: 'one' is invalid: expected a number, got str"),
    ("objects:\n  - {name: a, shape: sphere, x: 1, y: 1, z: -1, radius: 0.1}",
     r"objects\[0\].z: -1 is invalid: out of range, allowed float in 0..1000000"),
    ("objects:\n  - {name: a, shape: sphere, x: 1, y: 1, radius: 0.1}\n"
     "obstacles:\n  - {name: a, shape: box, x: 1, y: 1, width: 1, depth: 1, height: 1}",
     r":4: obstacles\[0\].name: the name is already used by objects\[0\]"),
    ("objects:\n  - {name: p, shape: poster, x: 1, y: 1, width: 1, height: 1}",
     r":2: objects\[0\].image: missing \(a poster shows an image file\)"),
    ("objects:\n  - {name: p, shape: poster, x: 1, y: 1, width: 1, height: 1, image: missing.png}",
     r":2: objects\[0\].image: image file .*missing\.png: file not found"),
    ("objects:\n  - {name: s, shape: sphere, radius: 0.1, path: [[0, 0], [1, 1]], speed: 1}",
     r":2: objects\[0\].path: only obstacles can move"),
    ("obstacles:\n  - {name: w, shape: box, width: 1, depth: 1, height: 1, x: 1, path: [[0, 0], [1, 1]], speed: 1}",
     r":2: obstacles\[0\].x: unknown key "
     r"\(allowed: name, shape, z, yaw, color, width, depth, height, path, speed, avoid\)"),
    ("obstacles:\n  - {name: w, shape: sphere, radius: 1, x: 1, y: 1}",
     r":2: obstacles\[0\].shape: 'sphere' is invalid: one of box, cylinder"),
    ("obstacles:\n  - {name: w, shape: cylinder, radius: 1, height: 1, path: [[0, 0]], speed: 1}",
     r":2: obstacles\[0\].path: \[\[0, 0\]\] is invalid: expected \[start, end\], each \[x, y\]"),
    ("obstacles:\n  - {name: w, shape: cylinder, radius: 1, height: 1, path: [[0, 0], [1, 1]], speed: 0}",
     r":2: obstacles\[0\].speed: 0 is invalid: out of range, allowed float in \(0\.\.1000000\]"),
    ("walls: {height: 0}", r":1: walls.height: 0 is invalid: out of range, allowed float in \(0\.\.1000\]"),
    ("walls: {thickness: 1}", r":1: walls.thickness: unknown key \(allowed: height, color\)"),
    ("robots: []", r":1: robots: unknown key \(allowed: map, walls, floor, background, objects, obstacles\)"),
    ("objects: {name: a}", r":1: objects: \{'name': 'a'\} is invalid: "
     r"expected a list, each an object: a mapping of name, shape, \.\.\., got dict"),
    ("- 1\n- 2", r":1: \[1, 2\] is invalid: expected a mapping of map, walls, floor, background, objects, obstacles"),
    ("objects: [\n", r"not valid YAML"),
    ("a: &x 1\nb: *x", r"aliases"),
])
def test_world_file_errors_name_the_file_line_object_and_field(tmp_path: Path, text: str, message: str):
    path = tmp_path / "bad.world.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(WorldError, match=message) as info:
        load_world(path)
    assert str(info.value).startswith(str(path))


def test_world_file_that_cannot_be_read(tmp_path: Path):
    with pytest.raises(WorldError, match=r"nowhere\.yaml: world file not found"):
        load_world(tmp_path / "nowhere.yaml")
    with pytest.raises(WorldError, match="is a folder"):
        load_world(tmp_path)
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    with pytest.raises(WorldError, match="FIFO"):
        load_world(fifo)


def test_poster_images_are_capped_before_decoding(tmp_path: Path):
    # A PNG header claiming 100000 x 100000 pixels: refused from the header, never decoded.
    header = b"\x89PNG\r\n\x1a\n" + b"\x00\x00\x00\x0dIHDR" + (100000).to_bytes(4, "big") * 2 + b"\x08\x02\x00\x00\x00"
    (tmp_path / "huge.png").write_bytes(header + b"\x00" * 64)
    (tmp_path / "text.png").write_text("not an image")
    for name, message in (("huge.png", r"image of 100000x100000: 10,000,000,000 pixels, over the limit of "
                                       r"100,000,000 pixels \(set OBJREC_MAX_IMAGE_PIXELS to raise it\)"),
                          ("text.png", r"not a readable image \(not PNG, JPEG, BMP, TIFF, WebP")):
        text = f"objects:\n  - {{name: p, shape: poster, x: 1, y: 1, width: 1, height: 1, image: {name}}}"
        with pytest.raises(WorldError, match=rf"w.yaml:2: objects\[0\].image: .*{message}"):
            parse_world(text, tmp_path / "w.yaml")
    jpeg = cv2.imencode(".jpg", np.full((30, 50, 3), 90, np.uint8))[1].tobytes()
    (tmp_path / "ok.jpg").write_bytes(jpeg)
    world = parse_world("objects: [{name: p, shape: poster, x: 1, y: 1, width: 1, height: 1, image: ok.jpg}]",
                        tmp_path / "w.yaml")
    assert world.objects[0].image.shape == (30, 50, 3)


def test_an_empty_world_file_is_an_empty_world(tmp_path: Path):
    world = parse_world("", tmp_path / "w.yaml")
    assert world.objects == () and world.obstacles == () and world.wall_height == 2.0


def test_without_and_moved_give_modified_copies(world_file: Path):
    world = load_world(world_file)
    absent = world.without("red_can")
    assert "red_can" not in absent.names and "red_can" in world.names
    assert len(absent.objects) == 3 and len(absent.obstacles) == 2
    moved = world.moved("crate", 0.5, -0.25)
    assert (moved.get("crate").x, moved.get("crate").y) == (3.5, 0.75)
    assert (world.get("crate").x, world.get("crate").y) == (3.0, 1.0)
    walker = world.moved("walker", 0.0, 1.0).get("walker")
    assert isinstance(walker, MovingObstacle) and (walker.start, walker.end) == ((1.0, 2.0), (4.0, 2.0))
    assert world.without("walker").obstacles == world.obstacles[:1]
    for change in (lambda: world.without("ghost"), lambda: world.moved("ghost", 1, 1)):
        with pytest.raises(KeyError, match="ghost"):
            change()
    assert [o.name for o in objects_near(world, 2.0, 1.5, 1.2)] == ["red_can", "crate"]


def test_footprints_and_collisions():
    box = WorldObject("box", "box", 2.0, 2.0, yaw=math.pi / 4, width=0.4, depth=1.0, height=0.5)
    can = WorldObject("can", "cylinder", 4.0, 2.0, radius=0.3, height=1.0)
    poster = WorldObject("poster", "poster", 1.0, 3.0, yaw=0.0, width=1.0, height=0.5)
    walker = MovingObstacle(WorldObject("w", "cylinder", 0.0, 0.0, radius=0.2, height=1.0), (0.0, 0.0),
                            (0.0, 2.0), 1.0)
    world = World((box, can, poster), (walker,))
    fps = {fp.name: fp for fp in world.footprint_at(1.0)}
    assert fps["can"].is_circle and fps["can"].radius == 0.3
    assert (fps["box"].half_x, fps["box"].half_y) == (0.5, 0.2)
    assert (fps["poster"].half_x, fps["poster"].half_y) == (POSTER_THICKNESS / 2, 0.5)
    assert (fps["w"].x, fps["w"].y) == (0.0, 1.0)
    corners = fps["box"].corners()
    assert corners[0] == pytest.approx([2.0 + (0.5 - 0.2) / math.sqrt(2), 2.0 + (0.5 + 0.2) / math.sqrt(2)])
    # Along the box's long axis (45 degrees) the surface is 0.5 m from the centre; across it 0.2 m.
    diag = (math.cos(math.pi / 4), math.sin(math.pi / 4))
    assert fps["box"].distance(2.0 + 0.7 * diag[0], 2.0 + 0.7 * diag[1]) == pytest.approx(0.2)
    assert world.collides(2.0 + 0.6 * diag[0], 2.0 + 0.6 * diag[1], 0.11)
    assert not world.collides(2.0 + 0.6 * diag[0], 2.0 + 0.6 * diag[1], 0.09)
    assert world.collides(2.0 - 0.25 * diag[1], 2.0 + 0.25 * diag[0], 0.06)  # across: 0.2 m + 0.05
    assert not world.collides(2.0 - 0.25 * diag[1], 2.0 + 0.25 * diag[0], 0.04)
    assert world.collides(4.0, 2.49, 0.2) and not world.collides(4.0, 2.51, 0.2)
    assert world.collides(1.0, 3.4, 0.02) and not world.collides(1.0 + 0.02, 3.0, 0.005)
    # The moving obstacle collides where it is at that time only.
    assert world.collides(0.0, 1.0, 0.1, t=1.0) and not world.collides(0.0, 1.0, 0.1, t=0.0)
    assert world.collides(0.0, 0.0, 0.1, t=4.0)


def test_ray_distances_meet_circles_and_rotated_boxes():
    box = WorldObject("box", "box", 3.0, 0.0, yaw=math.pi / 4, width=1.0, depth=1.0, height=0.5)
    can = WorldObject("can", "cylinder", 0.0, 2.0, radius=0.5, height=1.0)
    world = World((box, can))
    d = world.ray_distances(0.0, 0.0, [0.0, math.pi / 2, math.pi, math.atan2(2.0, 0.5)], 10.0)
    assert d[0] == pytest.approx(3.0 - math.sqrt(0.5))  # a corner of the diamond
    assert d[1] == pytest.approx(1.5)
    assert np.isinf(d[2])  # nothing behind
    # A tangent-ish ray into the circle: exact intersection.
    a = math.atan2(2.0, 0.5)
    b = -2.0 * math.sin(a)  # half the linear coefficient, from the origin to the centre (0, 2)
    expected = -b - math.sqrt(b * b - (4.0 - 0.25))
    assert d[3] == pytest.approx(expected)
    assert np.isinf(world.ray_distances(0.0, 0.0, [0.0], 2.0)[0])  # beyond max_range
    assert world.ray_distances(3.0, 0.0, [1.0], 5.0)[0] == 0.0  # from inside


def test_the_simulation_collides_with_world_objects():
    world = World((WorldObject("can", "cylinder", 3.0, 2.0, radius=0.3, height=1.0),))
    sim = Simulation(room(), Pose2D(1.0, 2.0, 0.0), world=world)
    sim.teleop = (0.5, 0.0)
    sim.run_for(10.0)
    assert sim.collisions == 1
    assert 3.0 - 0.3 - 0.18 - 0.06 < sim.robot.x <= 3.0 - 0.3 - 0.18
    plain = Simulation(room(), Pose2D(1.0, 2.0, 0.0))
    plain.teleop = (0.5, 0.0)
    plain.run_for(10.0)
    assert plain.robot.x > 5.0  # without the world it drives on to the wall
    with pytest.raises(StartPoseError, match="inside an obstacle"):
        Simulation(room(), Pose2D(3.0, 2.1, 0.0), world=world)


def test_a_moving_obstacle_runs_into_the_robots_way():
    walker = MovingObstacle(WorldObject("w", "cylinder", 3.0, 0.5, radius=0.25, height=1.7), (3.0, 0.5),
                            (3.0, 3.5), 1.0, avoid="none")  # blind to the robot: it walks into it
    sim = Simulation(room(), Pose2D(1.0, 2.0, 0.0), world=World((), (walker,)))
    sim.teleop = (0.3, 0.0)  # crosses the walker's path at y = 2 while it goes up and down
    sim.run_for(12.0)
    bumps = sim.events.of_type("collision")
    assert sim.collisions >= 1 and bumps
    first = bumps[0]
    wx, wy = walker.position_at(first["t"])
    # The robot was stopped where the walker (at that moment) stood within a step of its disc.
    assert math.hypot(first["x"] - wx, first["y"] - wy) < 0.25 + 0.18 + 0.05


def test_the_laser_sees_world_obstacles_but_the_scan_is_unchanged_without_them():
    world = World((), (WorldObject("box", "box", 3.0, 2.0, width=1.0, depth=0.4, height=0.5),))
    sim = Simulation(room(), Pose2D(1.0, 2.0, 0.0), world=world)
    scan = sim.scan()
    assert scan.ranges[320] == pytest.approx(3.0 - 0.2 - 1.0, abs=1e-6)  # exact, not a cell
    assert scan.ranges[0] == pytest.approx((2.0 - RES) / math.sin(-scan.angles()[0]), abs=RES)  # south wall
    plain = Simulation(room(), Pose2D(1.0, 2.0, 0.0)).scan()
    assert plain.ranges[320] == pytest.approx(6.0 - RES - 1.0, abs=RES)
    assert np.array_equal(Simulation(room(), Pose2D(1.0, 2.0, 0.0), world=World()).scan().ranges, plain.ranges)


def test_the_laser_sees_a_moving_obstacle_where_it_is():
    walker = MovingObstacle(WorldObject("w", "cylinder", 3.0, 0.5, radius=0.25, height=1.7), (3.0, 0.5),
                            (3.0, 3.5), 1.0)
    sim = Simulation(room(), Pose2D(1.0, 2.0, 0.0), world=World((), (walker,)))
    assert sim.scan().ranges[320] == pytest.approx(6.0 - RES - 1.0, abs=RES)  # t = 0: at y = 0.5, aside
    sim.run_for(1.5)  # now at y = 2.0, straight ahead
    assert sim.scan().ranges[320] == pytest.approx(3.0 - 0.25 - 1.0, abs=1e-4)
