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
at the first at t = 0, facing along the path unless ``yaw`` is given; it is a body, never passing through
the robot: ``avoid: stop`` (the default) waits for it, ``sidestep`` steps round it, ``none`` is blind to it
(:mod:`navigation.walkers`). Every object and obstacle is solid
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

from declare import Choice, Float, Int, Str
from declare.fields import (
    Document,
    DocumentError,
    FilePath,
    Free,
    Invalid,
    ListOf,
    Place,
    Record,
    Value,
    Vector,
    document_from_text,
    not_blank,
    read_document,
)
from strictio import InputError, YAMLLimits
from strictio.image_size import image_size, read_image_file
from strictio.limits import IMAGE_PIXELS, POSTER_PIXELS, check

from .geometry import Pose2D
from .laser import LaserScan
from .maps import MAX_COORDINATE, MAX_YAW, decode_image
from .walkers import AVOID_MODES, WalkerTrack

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
#: The largest size of an object or obstacle, metres: beyond it a value is a typo.
MAX_SIZE = 1000.0

Color = tuple[int, int, int]
DEFAULT_OBJECT_COLOR: Color = (128, 128, 128)
DEFAULT_POSTER_BACK: Color = (225, 225, 225)
DEFAULT_OBSTACLE_COLOR: Color = (70, 110, 150)
DEFAULT_WALL_COLOR: Color = (200, 205, 210)
DEFAULT_FLOOR_COLOR: Color = (110, 115, 120)
DEFAULT_BACKGROUND_COLOR: Color = (235, 235, 235)


#: A world file that cannot be used: the one error of every file reader (file, line, key path, value, rule).
WorldError = DocumentError


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
    #: How it reacts to the robot: ``stop``, ``sidestep`` or ``none`` (see :mod:`navigation.walkers`).
    avoid: str = "stop"
    #: Where it really went, in a simulation's live copy of the world (:meth:`World.live`); None: scripted.
    track: WalkerTrack | None = field(default=None, compare=False, repr=False)

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
        if self.track is not None:
            placed = self.track.at(t)
            if placed is not None:
                return placed
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
                              (self.end[0] + dx, self.end[1] + dy), self.speed, self.avoid)


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

    def live(self) -> World:
        """A copy whose moving obstacles record where they really go (a fresh :class:`WalkerTrack` each).

        A simulation steps its own live copy (:class:`navigation.walkers.Crowd`), so walkers that stop for
        the robot are where the collision check, the laser and the camera look for them at every time.
        """
        return replace(self, obstacles=tuple(replace(o, track=WalkerTrack()) if isinstance(o, MovingObstacle) else o
                                             for o in self.obstacles))

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

    def collides_static(self, x: float, y: float, radius: float) -> bool:
        """Whether a disc overlaps an object or a standing obstacle (where a walker cannot step)."""
        return any(fp.distance(x, y) < radius for fp in self._static
                   if abs(x - fp.x) < fp.radius + radius and abs(y - fp.y) < fp.radius + radius)

    def moving_overlap(self, x: float, y: float, radius: float, t: float) -> str | None:
        """The name of a moving obstacle a disc of ``radius`` at (x, y) overlaps at time ``t``, if any."""
        return next((o.name for o in self._moving if o.at(t).footprint().distance(x, y) < radius), None)

    def colliding(self, x: float, y: float, radius: float, t: float = 0.0) -> list[str]:
        """The names of the objects and obstacles a disc of ``radius`` at (x, y) overlaps at time ``t`` (what a
        refused start pose says it is inside of)."""
        return [thing.name for thing in self.solids_at(t) if thing.footprint().distance(x, y) < radius]

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
def _color(default: Color) -> Vector:
    return Vector(Int(0, "0-255", min=0, max=255), ("blue", "green", "red"), default=default)


_COORDINATE = Float(0.0, "metres in the map frame", min=-MAX_COORDINATE, max=MAX_COORDINATE)
_POINT = Vector(_COORDINATE, ("x", "y"))
_SIZE = Value(Float(0.1, "size in metres", min=0.0, min_open=True, max=MAX_SIZE), required=True)


def _thing_fields(shape: str, moving: bool, color: Color) -> dict[str, Any]:
    """The table of one object or obstacle: common fields, the shape's sizes, a poster's image, a path."""
    fields: dict[str, Any] = {
        "name": Value(Str("", "the object's name"), required=True, check=not_blank),
        "shape": Str("", "the shape"),
    }
    if not moving:
        fields |= {"x": Value(_COORDINATE, required=True), "y": Value(_COORDINATE, required=True)}
    fields |= {
        "z": Float(0.0, "height of the base above the floor, metres", min=0.0, max=MAX_COORDINATE),
        "yaw": Value(Float(0.0, "heading, radians", min=-MAX_YAW, max=MAX_YAW), default=None),
        "color": _color(DEFAULT_POSTER_BACK if shape == "poster" else color),
    }
    fields |= {key: _SIZE for key in SIZE_FIELDS[shape]}
    if shape == "poster":
        fields["image"] = FilePath(required=True, doc="a poster shows an image file")
    if moving:
        fields["path"] = Vector(_POINT, ("start", "end"), required=True, doc="a speed needs a path")
        fields["speed"] = Value(Float(0.5, "m/s", min=0.0, min_open=True, max=MAX_COORDINATE), required=True)
        fields["avoid"] = Choice("stop", AVOID_MODES)
    return fields


class _Thing(Free):
    """One entry of ``objects`` or ``obstacles``: its shape (and whether it moves) chooses its table."""

    def __init__(self, section: str, shapes: tuple[str, ...], color: Color) -> None:
        super().__init__(required=True)
        self.section, self.shapes, self.color = section, shapes, color

    def convert(self, value: Any, at: Place) -> WorldObject | MovingObstacle:
        if not isinstance(value, dict):
            raise Invalid(f"expected a mapping of an object's fields, got {type(value).__name__}")
        if "name" not in value:
            raise at.key("name").fail("missing")
        if "shape" not in value:
            raise at.key("shape").fail("missing")
        shape = Value(Choice(self.shapes[0], self.shapes)).read(value["shape"], at.key("shape"))
        moving = "path" in value or "speed" in value
        if moving and self.section != "obstacles":
            raise at.key("path" if "path" in value else "speed").fail("only obstacles can move")
        raw = Record(_thing_fields(shape, moving, self.color)).read(value, at)
        sizes = {key: raw[key] for key in SIZE_FIELDS[shape]}
        if moving:
            start, end = raw["path"]
            yaw = raw["yaw"] if raw["yaw"] is not None else math.atan2(end[1] - start[1], end[0] - start[0])
            body = WorldObject(raw["name"], shape, start[0], start[1], raw["z"], yaw, color=raw["color"], **sizes)
            return MovingObstacle(body, start, end, raw["speed"], raw["avoid"])
        image, image_path = None, None
        if shape == "poster":
            image_path = raw["image"]
            try:
                image = read_image(image_path)
            except InputError as exc:
                raise at.key("image").fail(f"image file {image_path}: {exc.message}") from None
        return WorldObject(raw["name"], shape, raw["x"], raw["y"], raw["z"], raw["yaw"] or 0.0, color=raw["color"],
                           image=image, image_path=image_path, **sizes)

    def describe(self) -> str:
        return f"an {self.section[:-1]}: a mapping of name, shape, ..."


#: What a world file holds.
WORLD_FIELDS = Record({
    "map": FilePath(doc="the map YAML this world belongs to"),
    "walls": Record({"height": Value(Float(2.0, "metres", min=0.0, min_open=True, max=MAX_SIZE)),
                     "color": _color(DEFAULT_WALL_COLOR)}),
    "floor": Record({"color": _color(DEFAULT_FLOOR_COLOR)}),
    "background": Record({"color": _color(DEFAULT_BACKGROUND_COLOR)}),
    "objects": ListOf(_Thing("objects", OBJECT_SHAPES, DEFAULT_OBJECT_COLOR), null_is_empty=True),
    "obstacles": ListOf(_Thing("obstacles", OBSTACLE_SHAPES, DEFAULT_OBSTACLE_COLOR), null_is_empty=True),
}, null_is_empty=True)


def _world(document: Document) -> World:
    """The world a parsed document describes, every field checked against :data:`WORLD_FIELDS`."""
    at = document.root
    raw = WORLD_FIELDS.read(document.data, at)
    seen: dict[str, str] = {}
    for section in ("objects", "obstacles"):
        for i, thing in enumerate(raw[section]):
            if thing.name in seen:
                raise at.key(section).item(i).key("name").fail(f"the name is already used by {seen[thing.name]}")
            seen[thing.name] = f"{section}[{i}]"
    return World(raw["objects"], raw["obstacles"], wall_height=raw["walls"]["height"],
                 wall_color=raw["walls"]["color"], floor_color=raw["floor"]["color"],
                 background_color=raw["background"]["color"], source=document.path, map_path=raw["map"])


#: The long side a poster is kept at: the camera draws 640x480 frames, so a poster filling the view shows at most
#: some 640 of its pixels across; 1024 keeps every poster at most 3 MB however large its file (eight
#: posters at the image pixel limit took 2.5 GB).
POSTER_SIDE = 1024


def read_image(path: Path) -> np.ndarray:
    """A BGR uint8 image read through strictio: a regular file whose header is within the pixel limits
    (``OBJREC_MAX_IMAGE_PIXELS``, then ``OBJREC_MAX_POSTER_PIXELS``), checked before decoding; InputError
    otherwise. Larger than :data:`POSTER_SIDE` on its long side, it is scaled down at once."""
    header = image_size(path)  # both limits from the header, before the file is read
    if header is not None:
        check(path, IMAGE_PIXELS, header[0] * header[1], f"image of {header[0]}x{header[1]}")
        check(path, POSTER_PIXELS, header[0] * header[1], f"poster of {header[0]}x{header[1]}")
    data, size = read_image_file(path)
    check(path, POSTER_PIXELS, size[0] * size[1], f"poster of {size[0]}x{size[1]}")
    pixels = decode_image(data, path, cv2.IMREAD_COLOR)
    del data
    longest = max(pixels.shape[:2])
    if longest > POSTER_SIDE:
        scale = POSTER_SIDE / longest
        width, height = max(1, round(pixels.shape[1] * scale)), max(1, round(pixels.shape[0] * scale))
        pixels = cv2.resize(pixels, (width, height), interpolation=cv2.INTER_AREA)
    return np.ascontiguousarray(pixels)


def parse_world(text: str, path: str | Path = "<world>") -> World:
    """Validate the text of a world file; ``path`` names it in errors and anchors relative file names."""
    return _world(document_from_text(text, path, WORLD_YAML_LIMITS))


def load_world(path: str | Path) -> World:
    """Load a world file; raises :class:`DocumentError` naming the file, line, key path and value on bad input."""
    world = _world(read_document(path, WORLD_YAML_LIMITS, "world"))
    log.info("loaded world %s: %d objects, %d obstacles", path, len(world.objects), len(world.obstacles))
    return world


def objects_near(world: World, x: float, y: float, distance: float) -> list[WorldObject]:
    """The objects (not obstacles) whose centre lies within ``distance`` of (x, y): what a pose can check."""
    return [o for o in world.objects if math.hypot(o.x - x, o.y - y) <= distance]
