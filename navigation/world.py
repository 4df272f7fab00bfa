"""The world file: what stands in the map's rooms besides the walls, like a Stage world file beside its map.

A map says where the walls are; an inspection needs more: the objects the robot is to check (cylinders,
boxes, spheres and flat textured posters, each with a name, pose, size and colour) and obstacles the map
does not know (static boxes or cylinders, and ones that move back and forth along a segment). The world
file lists them in the map frame. The simulator's collision check and laser consult the world, so the
robot bumps into and sees what stands there, and the RGB-D camera (:mod:`navigation.camera`) draws it.

Example (``lab.world.yaml`` beside ``lab.yaml``)::

    map: lab.yaml                       # optional: the map this world belongs to
    walls: {height: 2.0, color: [200, 205, 210]}   # optional; colours are BGR, 0-255
    floor: {color: [110, 115, 120]}
    objects:
      - {name: red_can, shape: cylinder, x: 2.0, y: 1.5, radius: 0.06, height: 0.25, color: [30, 30, 200]}
      - {name: crate, shape: box, x: 3.0, y: 1.0, yaw: 0.3, width: 0.4, depth: 0.3, height: 0.3}
      - {name: ball, shape: sphere, x: 1.0, y: 3.0, z: 0.4, radius: 0.1, color: [200, 60, 20]}
      - {name: sign, shape: poster, x: 0.06, y: 2.0, z: 0.5, yaw: 0.0, width: 0.6, height: 0.4,
         image: sign.png}
    obstacles:
      - {name: bin, shape: box, x: 4.0, y: 2.5, width: 0.4, depth: 0.4, height: 0.6}
      - {name: walker, shape: cylinder, radius: 0.25, height: 1.7, path: [[1, 1], [4, 1]], speed: 0.4}

Conventions: ``x, y`` is the centre of the footprint; ``z`` is the height of the object's base above the
floor (a sphere's centre is at ``z + radius``); ``yaw`` (radians) is the heading the object faces. A box's
``depth`` runs along that heading and its ``width`` across it; a poster is ``width`` wide across the
heading, ``height`` tall, shows its image on the side it faces (+yaw) and its ``color`` on the back. A
moving obstacle goes from the first point of ``path`` to the second and back at ``speed`` m/s, starting
at the first at t = 0, facing along the path unless ``yaw`` is given. Every object and obstacle is solid
from the floor up (a column), for collisions and for the laser. Errors name the file, the line, the
object and the field.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from strictio import InputError, YAMLLimits, read_text, yaml_text
from strictio.image_size import read_image_file

from .geometry import Pose2D
from .laser import LaserScan
from .maps import MAX_COORDINATE, MAX_YAW, decode_image, finite_number, long_integer_message, shown_value

log = logging.getLogger(__name__)

#: A world file is a list of a few dozen things; a megabyte is plenty and never a bomb.
WORLD_YAML_LIMITS = YAMLLimits(max_bytes=1024 * 1024, max_depth=8)
#: A poster is a board this thick for collisions and the laser (the camera draws it as a plane).
POSTER_THICKNESS = 0.02

OBJECT_SHAPES = ("cylinder", "box", "sphere", "poster")
OBSTACLE_SHAPES = ("box", "cylinder")
SIZE_FIELDS: dict[str, tuple[str, ...]] = {
    "cylinder": ("radius", "height"),
    "box": ("width", "depth", "height"),
    "sphere": ("radius",),
    "poster": ("width", "height"),
}
_COMMON_FIELDS = ("name", "shape", "x", "y", "z", "yaw", "color")
_MOVING_FIELDS = ("name", "shape", "z", "yaw", "color", "path", "speed")

Color = tuple[int, int, int]
DEFAULT_OBJECT_COLOR: Color = (128, 128, 128)
DEFAULT_POSTER_BACK: Color = (225, 225, 225)
DEFAULT_OBSTACLE_COLOR: Color = (70, 110, 150)
DEFAULT_WALL_COLOR: Color = (200, 205, 210)
DEFAULT_FLOOR_COLOR: Color = (110, 115, 120)
DEFAULT_BACKGROUND_COLOR: Color = (235, 235, 235)


class WorldError(ValueError):
    """A world file that cannot be used; the message names the file, the line, the object and the field."""


@dataclass(frozen=True, eq=False)
class WorldObject:
    """One solid thing placed in the map frame: an object to inspect or a static obstacle.

    Size fields that do not apply to the shape are 0. ``image`` is the poster's picture (BGR uint8), read
    from ``image_path``; other shapes have none.
    """

    name: str
    shape: str
    x: float
    y: float
    z: float = 0.0
    yaw: float = 0.0
    radius: float = 0.0
    width: float = 0.0
    depth: float = 0.0
    height: float = 0.0
    color: Color = DEFAULT_OBJECT_COLOR
    image: np.ndarray | None = field(default=None, repr=False)
    image_path: Path | None = None

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    @property
    def top(self) -> float:
        """Height of the highest point above the floor."""
        return self.z + (2.0 * self.radius if self.shape == "sphere" else self.height)

    @property
    def centre(self) -> tuple[float, float, float]:
        """The middle of the solid in the map frame (z up): where a detector should place it."""
        return (self.x, self.y, 0.5 * (self.z + self.top))

    def shifted(self, dx: float, dy: float) -> WorldObject:
        return replace(self, x=self.x + dx, y=self.y + dy)

    def footprint(self) -> Footprint:
        """The solid's outline on the floor, for collisions and the laser."""
        if self.shape in ("cylinder", "sphere"):
            return Footprint(self.name, self.x, self.y, self.radius)
        if self.shape == "box":
            half_x, half_y = 0.5 * self.depth, 0.5 * self.width
        else:  # poster: a thin board across its heading
            half_x, half_y = 0.5 * POSTER_THICKNESS, 0.5 * self.width
        return Footprint(self.name, self.x, self.y, math.hypot(half_x, half_y), half_x, half_y, self.yaw)


@dataclass(frozen=True, eq=False)
class MovingObstacle:
    """A box or cylinder going back and forth between ``start`` and ``end`` at ``speed`` (m/s).

    ``body`` holds the shape, size and colour (its x, y are the start). At t = 0 it is at ``start``; it
    reaches ``end`` after length / speed seconds and turns back at once, forever.
    """

    body: WorldObject
    start: tuple[float, float]
    end: tuple[float, float]
    speed: float

    @property
    def name(self) -> str:
        return self.body.name

    @property
    def shape(self) -> str:
        return self.body.shape

    @property
    def length(self) -> float:
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])

    def position_at(self, t: float) -> tuple[float, float]:
        length = self.length
        if length <= 0.0 or self.speed <= 0.0:
            return self.start
        d = math.fmod(self.speed * max(t, 0.0), 2.0 * length)
        f = (d if d <= length else 2.0 * length - d) / length
        return (self.start[0] + f * (self.end[0] - self.start[0]), self.start[1] + f * (self.end[1] - self.start[1]))

    def at(self, t: float) -> WorldObject:
        """The body where it is at simulated time ``t``."""
        x, y = self.position_at(t)
        return replace(self.body, x=x, y=y)

    def shifted(self, dx: float, dy: float) -> MovingObstacle:
        return MovingObstacle(self.body.shifted(dx, dy), (self.start[0] + dx, self.start[1] + dy),
                              (self.end[0] + dx, self.end[1] + dy), self.speed)


Obstacle = WorldObject | MovingObstacle


@dataclass(frozen=True)
class Footprint:
    """A solid's outline on the floor: a circle (``half_x == half_y == 0``) or a rotated rectangle.

    ``radius`` is the circle's radius, or the rectangle's bounding radius (for quick rejection).
    """

    name: str
    x: float
    y: float
    radius: float
    half_x: float = 0.0
    half_y: float = 0.0
    yaw: float = 0.0

    @property
    def is_circle(self) -> bool:
        return self.half_x == 0.0 and self.half_y == 0.0

    def corners(self) -> np.ndarray:
        """4x2 corners of a rectangle counter-clockwise (a circle gives its bounding square)."""
        hx, hy = (self.radius, self.radius) if self.is_circle else (self.half_x, self.half_y)
        yaw = 0.0 if self.is_circle else self.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        return local @ np.array([[c, s], [-s, c]]) + np.array([self.x, self.y])

    def distance(self, x: float, y: float) -> float:
        """Distance from a point to the footprint (0 inside)."""
        dx, dy = x - self.x, y - self.y
        if self.is_circle:
            return max(0.0, math.hypot(dx, dy) - self.radius)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        lx, ly = abs(c * dx + s * dy) - self.half_x, abs(-s * dx + c * dy) - self.half_y
        return math.hypot(max(lx, 0.0), max(ly, 0.0))

    def ray_distances(self, x: float, y: float, cos_a: np.ndarray, sin_a: np.ndarray) -> np.ndarray:
        """Distance along each unit direction from (x, y) to the outline (inf when missed, 0 from inside)."""
        fx, fy = x - self.x, y - self.y
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.is_circle:
                b = fx * cos_a + fy * sin_a
                c = fx * fx + fy * fy - self.radius * self.radius
                if c <= 0.0:
                    return np.zeros_like(cos_a)
                disc = b * b - c
                s = -b - np.sqrt(np.maximum(disc, 0.0))
                return np.where((disc >= 0.0) & (s >= 0.0), s, np.inf)
            c, s_ = math.cos(self.yaw), math.sin(self.yaw)
            px, py = c * fx + s_ * fy, -s_ * fx + c * fy
            if abs(px) <= self.half_x and abs(py) <= self.half_y:
                return np.zeros_like(cos_a)
            dx = c * cos_a + s_ * sin_a
            dy = -s_ * cos_a + c * sin_a
            enter, leave = _slab(px, dx, self.half_x)
            enter_y, leave_y = _slab(py, dy, self.half_y)
            enter = np.maximum(enter, enter_y)
            leave = np.minimum(leave, leave_y)
            return np.where((enter <= leave) & (enter >= 0.0), enter, np.inf)


def _slab(p: float, d: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit parameters of the rays p + t d through the slab |.| <= half (nan-free)."""
    safe = np.where(d == 0.0, 1e-300, d)
    t1 = (-half - p) / safe
    t2 = (half - p) / safe
    return np.minimum(t1, t2), np.maximum(t1, t2)


@dataclass(frozen=True)
class World:
    """Objects to inspect and obstacles unknown to the map, plus how walls, floor and background look.

    Immutable: :meth:`without` and :meth:`moved` return modified copies (to test absent and moved objects).
    """

    objects: tuple[WorldObject, ...] = ()
    obstacles: tuple[Obstacle, ...] = ()
    wall_height: float = 2.0
    wall_color: Color = DEFAULT_WALL_COLOR
    floor_color: Color = DEFAULT_FLOOR_COLOR
    background_color: Color = DEFAULT_BACKGROUND_COLOR
    source: Path | None = None
    map_path: Path | None = None
    _static: tuple[Footprint, ...] = field(init=False, repr=False, compare=False, default=())
    _moving: tuple[MovingObstacle, ...] = field(init=False, repr=False, compare=False, default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "objects", tuple(self.objects))
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        names = [thing.name for thing in (*self.objects, *self.obstacles)]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"names must be unique in a world, repeated: {', '.join(duplicates)}")
        static = [o.footprint() for o in self.objects]
        static += [o.footprint() for o in self.obstacles if isinstance(o, WorldObject)]
        object.__setattr__(self, "_static", tuple(static))
        object.__setattr__(self, "_moving", tuple(o for o in self.obstacles if isinstance(o, MovingObstacle)))

    # -- lookup and modified copies ----------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        return [thing.name for thing in (*self.objects, *self.obstacles)]

    def get(self, name: str) -> WorldObject | MovingObstacle:
        for thing in (*self.objects, *self.obstacles):
            if thing.name == name:
                return thing
        raise KeyError(f"no object or obstacle named {name!r} in the world (has: {', '.join(self.names)})")

    def without(self, name: str) -> World:
        """A copy without the object or obstacle ``name`` (KeyError when there is none)."""
        self.get(name)
        return replace(self, objects=tuple(o for o in self.objects if o.name != name),
                       obstacles=tuple(o for o in self.obstacles if o.name != name))

    def moved(self, name: str, dx: float, dy: float) -> World:
        """A copy with ``name`` shifted by (dx, dy) metres in the map frame (a moving one: its whole path)."""
        self.get(name)
        return replace(
            self,
            objects=tuple(o.shifted(dx, dy) if o.name == name else o for o in self.objects),
            obstacles=tuple(o.shifted(dx, dy) if o.name == name else o for o in self.obstacles))

    # -- geometry at a time ------------------------------------------------------------------------
    def solids_at(self, t: float = 0.0) -> list[WorldObject]:
        """Every object and obstacle placed where it is at simulated time ``t`` (what the camera draws)."""
        return [*self.objects, *(o.at(t) if isinstance(o, MovingObstacle) else o for o in self.obstacles)]

    def footprint_at(self, t: float = 0.0) -> list[Footprint]:
        """The floor outlines of everything solid at time ``t``."""
        return [*self._static, *(o.at(t).footprint() for o in self._moving)]

    def collides(self, x: float, y: float, radius: float, t: float = 0.0) -> bool:
        """Whether a disc of ``radius`` at (x, y) overlaps any object or obstacle at time ``t``."""
        for fp in self._static:
            if abs(x - fp.x) < fp.radius + radius and abs(y - fp.y) < fp.radius + radius \
                    and fp.distance(x, y) < radius:
                return True
        return any(o.at(t).footprint().distance(x, y) < radius for o in self._moving)

    def ray_distances(self, x: float, y: float, angles: np.ndarray | Sequence[float], max_range: float,
                      t: float = 0.0) -> np.ndarray:
        """Distance from (x, y) along each map-frame heading to the nearest solid (inf beyond ``max_range``)."""
        a = np.asarray(angles, dtype=np.float64)
        cos_a, sin_a = np.cos(a), np.sin(a)
        best = np.full(a.shape, np.inf)
        for fp in self.footprint_at(t):
            if math.hypot(fp.x - x, fp.y - y) - fp.radius > max_range:
                continue
            np.minimum(best, fp.ray_distances(x, y, cos_a, sin_a), out=best)
        best[best > max_range] = np.inf
        return best

    def add_to_scan(self, scan: LaserScan, pose: Pose2D, t: float, noise: float = 0.0,
                    rng: np.random.Generator | None = None) -> LaserScan:
        """A copy of a map-only scan where beams that hit an object or obstacle first stop there."""
        if not self.objects and not self.obstacles:
            return scan
        hits = self.ray_distances(pose.x, pose.y, pose.yaw + scan.angles(), scan.range_max, t)
        hits = np.maximum(hits, scan.range_min)
        closer = hits < scan.ranges
        ranges = scan.ranges.copy()
        if closer.any():
            found = hits[closer]
            if noise > 0.0:
                found = np.clip(found + (rng or np.random.default_rng(0)).normal(0.0, noise, found.size),
                                scan.range_min, scan.range_max)
            ranges[closer] = found
        return LaserScan(scan.angle_min, scan.angle_increment, ranges, scan.range_min, scan.range_max)


# -- loading -------------------------------------------------------------------------------------------
def _yaml_lines(text: str) -> dict[tuple[Any, ...], int]:
    """1-based line of every key and list item, by path (``("objects", 2, "radius")``)."""
    lines: dict[tuple[Any, ...], int] = {}
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return lines

    def walk(node: yaml.Node, path: tuple[Any, ...]) -> None:
        lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                lines[(*path, key.value)] = key.start_mark.line + 1
                walk(value, (*path, key.value))
        elif isinstance(node, yaml.SequenceNode):
            for i, value in enumerate(node.value):
                walk(value, (*path, i))

    if root is not None:
        walk(root, ())
    return lines


class _Reader:
    """Validates one world document, turning every problem into a WorldError that says where it is."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        self.lines = _yaml_lines(text)

    def fail(self, where: tuple[Any, ...], message: str, label: str = "") -> WorldError:
        line = next((self.lines[where[:n]] for n in range(len(where), 0, -1) if where[:n] in self.lines), None)
        parts = [str(self.path)]
        if line is not None:
            parts.append(f"line {line}")
        if label:
            parts.append(label)
        if len(where) > 2 and isinstance(where[1], int):
            parts.append(f"field '{'.'.join(map(str, where[2:]))}'")
        elif len(where) >= 1 and not isinstance(where[-1], int):
            parts.append(f"field '{'.'.join(map(str, where))}'")
        return WorldError(": ".join(parts) + f": {message}")

    def number(self, raw: dict[str, Any], key: str, where: tuple[Any, ...], label: str,
               default: float | None = None, positive: bool = False, minimum: float | None = None) -> float:
        if key not in raw:
            if default is None:
                raise self.fail(where, f"required field '{key}' is missing", label)
            return default
        value = finite_number(raw[key])
        if value is None:
            raise self.fail((*where, key), f"expected a number, got {shown_value(raw[key])}", label)
        bound = MAX_YAW if key == "yaw" else MAX_COORDINATE
        if abs(value) > bound:
            raise self.fail((*where, key), f"must lie within ±{bound:g}, got {value!r}", label)
        if positive and value <= 0.0:
            raise self.fail((*where, key), f"must be positive, got {value!r}", label)
        if minimum is not None and value < minimum:
            raise self.fail((*where, key), f"must be at least {minimum:g}, got {value!r}", label)
        return float(value)

    def color(self, raw: dict[str, Any], key: str, where: tuple[Any, ...], label: str, default: Color) -> Color:
        if key not in raw:
            return default
        value = raw[key]
        if (not isinstance(value, list) or len(value) != 3
                or not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 255 for v in value)):
            raise self.fail((*where, key), f"expected [blue, green, red] integers 0-255, got {value!r}", label)
        return (int(value[0]), int(value[1]), int(value[2]))

    def point(self, value: Any, where: tuple[Any, ...], label: str) -> tuple[float, float]:
        numbers = [n for n in (finite_number(v) for v in value) if n is not None] if isinstance(value, list) else []
        if len(numbers) != 2 or len(value) != 2:
            raise self.fail(where, f"expected a point [x, y], got {shown_value(value)}", label)
        x, y = numbers
        if max(abs(x), abs(y)) > MAX_COORDINATE:
            raise self.fail(where, f"must lie within ±{MAX_COORDINATE:g} m, got {shown_value(value)}", label)
        return (x, y)

    def mapping(self, value: Any, where: tuple[Any, ...], what: str, label: str = "") -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"expected a mapping of {what}, got {type(value).__name__}", label)
        return value

    def thing(self, raw: Any, section: str, index: int, shapes: tuple[str, ...],
              default_color: Color) -> WorldObject | MovingObstacle:
        where = (section, index)
        label = f"{section}[{index}]"
        raw = self.mapping(raw, where, "fields", label)
        name = raw.get("name")
        if not isinstance(name, str) or not name.strip():
            if "name" not in raw:
                raise self.fail(where, "required field 'name' is missing", label)
            raise self.fail((*where, "name"), f"expected a non-empty name, got {name!r}", label)
        label = f"{section[:-1]} '{name}' ({section}[{index}])"
        shape = raw.get("shape")
        if "shape" not in raw:
            raise self.fail(where, "required field 'shape' is missing", label)
        if shape not in shapes:
            raise self.fail((*where, "shape"), f"expected one of {', '.join(shapes)}, got {shape!r}", label)
        moving = "path" in raw or "speed" in raw
        allowed = (_MOVING_FIELDS if moving else _COMMON_FIELDS) + SIZE_FIELDS[shape]
        if shape == "poster":
            allowed += ("image",)
        for key in raw:
            if key not in allowed:
                hint = " (a moving obstacle has a path instead of x, y)" if moving and key in ("x", "y") else ""
                raise self.fail((*where, key), f"unknown field for a {'moving ' if moving else ''}{shape}{hint}; "
                                f"allowed: {', '.join(allowed)}", label)
        sizes = {key: self.number(raw, key, where, label, positive=True) for key in SIZE_FIELDS[shape]}
        for key, value in sizes.items():
            if value > 1000.0:
                raise self.fail((*where, key), f"unreasonably large ({value!r} m)", label)
        z = self.number(raw, "z", where, label, default=0.0, minimum=0.0)
        color = self.color(raw, "color", where, label, DEFAULT_POSTER_BACK if shape == "poster" else default_color)
        image, image_path = None, None
        if shape == "poster":
            image_path, image = self.poster_image(raw, where, label)
        if moving:
            if section != "obstacles":
                raise self.fail((*where, "path"), "only obstacles can move", label)
            if "path" not in raw:
                raise self.fail(where, "required field 'path' is missing (a speed needs a path)", label)
            path = raw["path"]
            if not isinstance(path, list) or len(path) != 2:
                raise self.fail((*where, "path"), f"expected two points [[x0, y0], [x1, y1]], got {path!r}", label)
            start = self.point(path[0], (*where, "path", 0), label)
            end = self.point(path[1], (*where, "path", 1), label)
            speed = self.number(raw, "speed", where, label, positive=True)
            heading = math.atan2(end[1] - start[1], end[0] - start[0])
            yaw = self.number(raw, "yaw", where, label, default=heading)
            body = WorldObject(name, shape, start[0], start[1], z, yaw, color=color, **sizes)
            return MovingObstacle(body, start, end, speed)
        x = self.number(raw, "x", where, label)
        y = self.number(raw, "y", where, label)
        yaw = self.number(raw, "yaw", where, label, default=0.0)
        return WorldObject(name, shape, x, y, z, yaw, color=color, image=image, image_path=image_path, **sizes)

    def poster_image(self, raw: dict[str, Any], where: tuple[Any, ...], label: str) -> tuple[Path, np.ndarray]:
        if "image" not in raw:
            raise self.fail(where, "required field 'image' is missing (a poster shows an image file)", label)
        name = raw["image"]
        if not isinstance(name, str) or not name.strip():
            raise self.fail((*where, "image"), f"expected an image file name, got {name!r}", label)
        image_path = Path(name)
        if not image_path.is_absolute():
            image_path = self.path.parent / image_path
        try:
            image = read_image(image_path)
        except InputError as exc:
            raise self.fail((*where, "image"), f"image file {image_path}: {exc.message}", label) from None
        return image_path, image


def read_image(path: Path) -> np.ndarray:
    """A BGR uint8 image read through strictio: a regular file whose header is within the pixel limit
    (``OBJREC_MAX_IMAGE_PIXELS``), checked before decoding; InputError otherwise."""
    data, _size = read_image_file(path)
    return np.ascontiguousarray(decode_image(data, path, cv2.IMREAD_COLOR))


def parse_world(text: str, path: str | Path = "<world>") -> World:
    """Validate the text of a world file; ``path`` names it in errors and anchors relative file names."""
    path = Path(path)
    try:
        raw = yaml_text(text, path, WORLD_YAML_LIMITS)
    except InputError as exc:
        raise WorldError(long_integer_message(text, exc)) from None
    reader = _Reader(path, text)
    if raw is None:
        raw = {}
    raw = reader.mapping(raw, (), "world fields (objects, obstacles, walls, floor, background, map)")
    known = ("map", "walls", "floor", "background", "objects", "obstacles")
    for key in raw:
        if key not in known:
            raise reader.fail((key,), f"unknown field; allowed: {', '.join(known)}")
    settings: dict[str, Any] = {}
    map_path = None
    if "map" in raw:
        if not isinstance(raw["map"], str) or not raw["map"].strip():
            raise reader.fail(("map",), f"expected a map YAML file name, got {raw['map']!r}")
        map_path = Path(raw["map"])
        if not map_path.is_absolute():
            map_path = path.parent / map_path
    for key, fields, default in (("walls", ("height", "color"), DEFAULT_WALL_COLOR),
                                 ("floor", ("color",), DEFAULT_FLOOR_COLOR),
                                 ("background", ("color",), DEFAULT_BACKGROUND_COLOR)):
        if key not in raw:
            continue
        section = reader.mapping(raw[key], (key,), ", ".join(fields))
        for sub in section:
            if sub not in fields:
                raise reader.fail((key, sub), f"unknown field; allowed: {', '.join(fields)}")
        settings[f"{'wall' if key == 'walls' else key}_color"] = reader.color(section, "color", (key,), "", default)
        if key == "walls":
            settings["wall_height"] = reader.number(section, "height", (key,), "", default=2.0, positive=True)
    things: dict[str, list[Any]] = {"objects": [], "obstacles": []}
    seen: dict[str, str] = {}
    for section, shapes, colour in (("objects", OBJECT_SHAPES, DEFAULT_OBJECT_COLOR),
                                    ("obstacles", OBSTACLE_SHAPES, DEFAULT_OBSTACLE_COLOR)):
        items = raw.get(section) or []
        if not isinstance(items, list):
            raise reader.fail((section,), f"expected a list of {section}, got {type(items).__name__}")
        for i, item in enumerate(items):
            thing = reader.thing(item, section, i, shapes, colour)
            if thing.name in seen:
                raise reader.fail((section, i, "name"), f"the name is already used by {seen[thing.name]}",
                                  f"{section[:-1]} '{thing.name}' ({section}[{i}])")
            seen[thing.name] = f"{section}[{i}]"
            things[section].append(thing)
    return World(tuple(things["objects"]), tuple(things["obstacles"]), source=path, map_path=map_path, **settings)


def load_world(path: str | Path) -> World:
    """Load a world file; raises :class:`WorldError` naming the file, line, object and field on bad input."""
    path = Path(path)
    try:
        text = read_text(path, WORLD_YAML_LIMITS.max_bytes)
    except InputError as exc:
        if exc.message == "file not found":
            raise WorldError(f"{path}: world file not found") from None
        raise WorldError(str(exc)) from None
    world = parse_world(text, path)
    log.info("loaded world %s: %d objects, %d obstacles", path, len(world.objects), len(world.obstacles))
    return world


def objects_near(world: World, x: float, y: float, distance: float) -> list[WorldObject]:
    """The objects (not obstacles) whose centre lies within ``distance`` of (x, y): what a pose can check."""
    return [o for o in world.objects if math.hypot(o.x - x, o.y - y) <= distance]
