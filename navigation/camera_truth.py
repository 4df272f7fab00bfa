"""What a simulated camera frame shows: the world's objects it drew, as ground truth in the optical frame.

The camera knows exactly what it drew, so each frame carries its own truth for free: every object with at
least one pixel in the image (whatever hides the rest of it), with its geometry in the camera's optical
frame (x right, y down, z forward, metres) and how much of it the sensor returned (``visible_points``:
pixels of it with a depth; an object beyond ``max_range`` or seen at a grazing angle has pixels but few
points). The layout is that of objrec's 3D truth shapes (``objrec3d.truth.TruthShape`` and its label file):
a cylinder's centre, radius, axis (toward the sensor, the detector's sign convention) and height; a
sphere's centre and radius; a box's centre, size along its local x, y, z and orientation (a quaternion
x, y, z, w). A poster is a box as thin as the board it hangs as (:data:`~navigation.world.POSTER_THICKNESS`).
This package imports no ``objrec_*``: the truth is plain data (:class:`SeenObject`, :meth:`SeenObject.as_dict`)
that the apps turn into a kind's truth objects and label files (``objrec3d.truth.as_truth_shape`` reads
the dict as it is).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .world import POSTER_THICKNESS

if TYPE_CHECKING:  # pragma: no cover
    from .camera import CameraPose, RGBDFrame
    from .world import WorldObject

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class SeenObject:
    """One world object (or obstacle) in one camera frame, in the optical frame (metres).

    - ``shape``: ``cylinder``, ``sphere`` or ``box`` (a world-file box or poster; ``source_shape`` says which).
    - ``centre``: the middle of the solid (a cylinder's or box's half height, a sphere's centre).
    - ``radius``, ``height``: a cylinder's; a sphere has its radius.
    - ``axis``: a cylinder's unit axis, pointing toward the sensor (as the shape detector reports it).
    - ``size``: a box's extent along its local x (the heading it faces in the world file, its ``depth``), y
      (its ``width``) and z (up, its ``height``); ``orientation``: the unit quaternion (x, y, z, w) turning
      those axes into the optical frame (:attr:`rotation` as a matrix).
    - ``pixels``: pixels the object covers in the image; ``visible_points``: those with a depth return;
      ``box_px``: the pixel rectangle they span (u0, v0, u1, v1, inclusive-exclusive).
    - ``obstacle``: an obstacle of the world file (clutter) rather than an object to inspect.
    """

    name: str
    shape: str
    centre: Vec3
    radius: float = 0.0
    axis: Vec3 | None = None
    height: float = 0.0
    size: Vec3 | None = None
    orientation: Quat = (0.0, 0.0, 0.0, 1.0)
    visible_points: int = 0
    pixels: int = 0
    box_px: tuple[int, int, int, int] | None = None
    obstacle: bool = False
    source_shape: str = ""

    @property
    def distance(self) -> float:
        """Distance from the optical centre to the object's centre, metres."""
        return math.sqrt(sum(c * c for c in self.centre))

    @property
    def rotation(self) -> np.ndarray:
        """The 3 x 3 matrix of :attr:`orientation` (columns: the box's local axes in the optical frame)."""
        x, y, z, w = self.orientation
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])

    def as_dict(self, extras: bool = False) -> dict[str, Any]:
        """The object in the 3D label file's layout, only its shape's fields (what ``objrec3d.truth`` reads);
        with ``extras`` also ``pixels``, ``box_px``, ``obstacle`` and ``source_shape`` (for a person's file)."""
        data: dict[str, Any] = {"name": self.name, "shape": self.shape, "centre": list(self.centre)}
        if self.shape in ("sphere", "cylinder"):
            data["radius"] = self.radius
        if self.shape == "cylinder":
            data["height"] = self.height
            data["axis"] = list(self.axis or (0.0, -1.0, 0.0))
        if self.shape == "box":
            data["size"] = list(self.size or (0.0, 0.0, 0.0))
            data["orientation"] = list(self.orientation)
        data["visible_points"] = self.visible_points
        if extras:
            data |= {"pixels": self.pixels, "box_px": None if self.box_px is None else list(self.box_px),
                     "obstacle": self.obstacle, "source_shape": self.source_shape}
        return data


def seen_objects(frame: RGBDFrame, obstacles: bool = False) -> list[SeenObject]:
    """The objects ``frame`` shows (with ``obstacles``, the world file's obstacles too), in world-file order.

    A frame made without the object layer (an :class:`~navigation.camera.RGBDFrame` built by hand) shows none.
    """
    ids = frame.object_ids
    if ids is None or not frame.solids:
        return []
    n = len(frame.solids)
    drawn = ids >= 0
    pixels = np.bincount(ids[drawn], minlength=n)
    visible = np.bincount(ids[drawn & np.isfinite(frame.depth)], minlength=n)
    limit = n if obstacles else frame.object_count
    seen = []
    for k in range(limit):
        if pixels[k] == 0:
            continue
        vs, us = np.nonzero(ids == k)
        box = (int(us.min()), int(vs.min()), int(us.max()) + 1, int(vs.max()) + 1)
        seen.append(describe(frame.solids[k], frame.camera_pose, int(pixels[k]), int(visible[k]), box,
                             k >= frame.object_count))
    return seen


def describe(solid: WorldObject, cam: CameraPose, pixels: int = 0, visible_points: int = 0,
             box_px: tuple[int, int, int, int] | None = None, obstacle: bool = False) -> SeenObject:
    """The truth of one solid seen by a camera at ``cam`` (its geometry only; the counts are given)."""
    rot = cam.rotation  # columns: the optical axes in the map frame; a map direction v is v @ rot optically
    centre = _vec(cam.map_to_camera(np.array(solid.centre, np.float64)))
    common: dict[str, Any] = {"pixels": pixels, "visible_points": visible_points, "box_px": box_px,
                              "obstacle": obstacle, "source_shape": solid.shape}
    if solid.shape == "cylinder":
        axis = np.array([0.0, 0.0, 1.0]) @ rot
        if float(axis @ -np.array(centre)) < 0.0:
            axis = -axis
        return SeenObject(solid.name, "cylinder", centre, solid.radius, _vec(axis), solid.height, **common)
    if solid.shape == "sphere":
        return SeenObject(solid.name, "sphere", centre, solid.radius, **common)
    c, s = math.cos(solid.yaw), math.sin(solid.yaw)
    local = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # columns: the solid's x, y, z in the map
    depth = solid.depth if solid.shape == "box" else POSTER_THICKNESS
    return SeenObject(solid.name, "box", centre, size=(depth, solid.width, solid.height),
                      orientation=quaternion(rot.T @ local), **common)


def quaternion(m: np.ndarray) -> Quat:
    """The unit quaternion (x, y, z, w), w >= 0, of a 3 x 3 rotation matrix (Shepperd's method)."""
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        k = math.sqrt(trace + 1.0) * 2
        q = ((m[2, 1] - m[1, 2]) / k, (m[0, 2] - m[2, 0]) / k, (m[1, 0] - m[0, 1]) / k, 0.25 * k)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        k = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = (0.25 * k, (m[0, 1] + m[1, 0]) / k, (m[0, 2] + m[2, 0]) / k, (m[2, 1] - m[1, 2]) / k)
    elif m[1, 1] > m[2, 2]:
        k = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = ((m[0, 1] + m[1, 0]) / k, 0.25 * k, (m[1, 2] + m[2, 1]) / k, (m[0, 2] - m[2, 0]) / k)
    else:
        k = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = ((m[0, 2] + m[2, 0]) / k, (m[1, 2] + m[2, 1]) / k, 0.25 * k, (m[1, 0] - m[0, 1]) / k)
    v = np.array(q) / math.sqrt(sum(x * x for x in q))
    if v[3] < 0:
        v = -v
    return (float(v[0]), float(v[1]), float(v[2]), float(v[3]))


def _vec(v: np.ndarray) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))
