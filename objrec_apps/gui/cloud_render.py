"""A software point renderer in NumPy: vectorised projection and a z-buffer, no OpenGL.

It works wherever Qt works (offscreen, over SSH, in CI) and draws a 307,200-point organized cloud in a few
tens of milliseconds on one core. ``CloudScene`` merges the stages of a 3D pipeline once per frame (the
original cloud in one colour, each filter's output in a colour of its own); ``OrbitCamera`` holds the view;
``render`` turns both into an RGB image.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: The original cloud's colour, then one colour per filter (RGB).
LAYER_COLOURS = [
    (150, 150, 150),
    (255, 150, 40),
    (60, 200, 255),
    (240, 80, 220),
    (120, 230, 90),
    (255, 230, 70),
    (255, 90, 90),
]
BACKGROUND = (28, 30, 34)
NEAR = 1e-3


def layer_colour(index: int) -> tuple[int, int, int]:
    if index == 0:
        return LAYER_COLOURS[0]
    return LAYER_COLOURS[1 + (index - 1) % (len(LAYER_COLOURS) - 1)]


def cloud_points(points: Any) -> np.ndarray | None:
    """The N x 3 float32 points of a layer (what ``Kind.points`` gives), or None for anything else."""
    if not isinstance(points, np.ndarray) or points.ndim != 2 or points.shape[1] != 3:
        return None
    return np.asarray(points, dtype=np.float32)


def _same_positions(a: np.ndarray, b: np.ndarray, valid_b: np.ndarray) -> bool:
    """Whether ``b`` is ``a`` with some points invalidated (an organized filter): checked on a sample."""
    index = np.flatnonzero(valid_b)
    if index.size == 0:
        return True
    sample = index[:: max(1, index.size // 512)]
    return bool(np.array_equal(a[sample], b[sample]))


@dataclass
class CloudScene:
    """The points of every layer, merged: ``points`` (M x 3) and ``owner`` (M, the layer index per point).

    A filter that keeps the cloud organized only invalidates points, so its output is the previous cloud
    minus some points: those points are recoloured rather than drawn twice, which keeps a 640x480 scene at
    307,200 points however many filters there are.
    """

    names: list[str] = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.empty((0, 3), np.float32))
    owner: np.ndarray = field(default_factory=lambda: np.empty(0, np.uint8))
    counts: list[int] = field(default_factory=list)

    @classmethod
    def from_layers(cls, layers: Sequence[tuple[str, Any]]) -> CloudScene:
        """Merge named N x 3 point arrays (the original first); anything else is left out."""
        groups: list[tuple[np.ndarray, np.ndarray]] = []  # (all points, owner with -1 = invalid)
        names, counts = [], []
        for name, cloud in layers:
            points = cloud_points(cloud)
            if points is None:
                continue
            names.append(name)
            valid = np.isfinite(points).all(axis=1)
            counts.append(int(valid.sum()))
            layer = len(names) - 1
            for all_points, owner in reversed(groups):
                if all_points.shape == points.shape and _same_positions(all_points, points, valid):
                    owner[valid] = layer
                    break
            else:
                owner = np.full(points.shape[0], -1, np.int16)
                owner[valid] = layer
                groups.append((points, owner))
        if not groups:
            return cls(names, counts=counts)
        merged_points, merged_owner = [], []
        for all_points, owner in groups:
            keep = owner >= 0
            merged_points.append(all_points[keep])
            merged_owner.append(owner[keep].astype(np.uint8))
        return cls(names, np.concatenate(merged_points), np.concatenate(merged_owner), counts)

    def thinned(self, budget: int) -> CloudScene:
        """At most about ``budget`` points: every k-th point of the scene (itself when it is small enough), for
        drawing while the camera moves. The legend's counts stay the full scene's; made once per scene."""
        step = -(-self.points.shape[0] // max(budget, 1))
        if step <= 1:
            return self
        cached = self.__dict__.get("_thinned")
        if cached is not None and cached[0] == step:
            return cached[1]
        thin = CloudScene(self.names, np.ascontiguousarray(self.points[::step]),
                          np.ascontiguousarray(self.owner[::step]), self.counts)
        thin.__dict__["_bounds"] = (thin.points, self.bounds())  # the same view box as the whole scene
        self.__dict__["_thinned"] = (step, thin)
        return thin

    def bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """A robust box around the points (2nd to 98th percentile), for fitting the view; computed once per
        scene, since views ask for it on every frame they draw (grid, clip planes)."""
        if self.points.shape[0] == 0:
            return None
        cached = self.__dict__.get("_bounds")
        if cached is not None and cached[0] is self.points:
            return cached[1]
        sample = self.points[:: max(1, self.points.shape[0] // 20000)]
        low, high = np.percentile(sample, [2, 98], axis=0)
        found = (low.astype(np.float64), high.astype(np.float64))
        self.__dict__["_bounds"] = (self.points, found)
        return found


@dataclass
class OrbitCamera:
    """A camera orbiting ``target``: yaw about the vertical (the sensor's -y), pitch about its right axis.

    Yaw and pitch zero look along +z with y down, i.e. as the depth sensor itself looks.
    """

    target: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    distance: float = 1.0
    yaw: float = 0.0
    pitch: float = 0.0
    fov_y: float = math.radians(50.0)

    def rotation(self) -> np.ndarray:
        """World-to-camera rotation; its rows are the camera's right, down and forward axes."""
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        yaw = np.array([[cy, 0, -sy], [0, 1, 0], [sy, 0, cy]])
        pitch = np.array([[1, 0, 0], [0, cp, sp], [0, -sp, cp]])
        return pitch @ yaw

    def position(self) -> np.ndarray:
        return self.target - self.distance * self.rotation()[2]

    def fit(self, bounds: tuple[np.ndarray, np.ndarray] | None, aspect: float = 4 / 3) -> None:
        """Look along +z (as the sensor does) from just far enough to see the whole box: the reset view.
        ``aspect`` is the view's width over its height."""
        self.yaw = self.pitch = 0.0
        if bounds is None:
            self.target, self.distance = np.array([0.0, 0.0, 1.0]), 1.0
            return
        low, high = bounds
        self.target = (low + high) / 2.0
        half = np.maximum((high - low) / 2.0, 1e-3)
        tan_v = math.tan(self.fov_y / 2.0)
        self.distance = 1.05 * (max(half[0] / (tan_v * max(aspect, 1e-3)), half[1] / tan_v) + half[2])

    def rotate(self, d_yaw: float, d_pitch: float) -> None:
        self.yaw = (self.yaw + d_yaw) % (2 * math.pi)
        self.pitch = float(np.clip(self.pitch + d_pitch, -math.pi / 2 + 1e-3, math.pi / 2 - 1e-3))

    def zoom(self, factor: float) -> None:
        self.distance = float(np.clip(self.distance * factor, 1e-3, 1e4))

    def pan(self, dx: float, dy: float, height: int) -> None:
        """Move the target by a drag of (dx, dy) widget pixels, so the scene follows the mouse."""
        metres_per_pixel = 2.0 * self.distance * math.tan(self.fov_y / 2.0) / max(height, 1)
        rotation = self.rotation()
        self.target = self.target - (dx * rotation[0] + dy * rotation[1]) * metres_per_pixel

    def focal(self, height: int) -> float:
        return (height / 2.0) / math.tan(self.fov_y / 2.0)

    def project(self, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """Widget coordinates (M x 2) and depth (M) of world points; depth <= NEAR means behind the camera."""
        rotation = self.rotation()
        camera = (np.asarray(points, dtype=np.float64) - self.position()) @ rotation.T
        depth = camera[:, 2]
        focal = self.focal(height)
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = camera[:, :2] * (focal / depth)[:, None] + (width / 2.0, height / 2.0)
        return uv, depth


def render(
    scene: CloudScene,
    camera: OrbitCamera,
    width: int,
    height: int,
    *,
    point_size: int = 1,
    hidden: frozenset[int] = frozenset(),
    shade: bool = True,
) -> np.ndarray:
    """Draw the scene: an RGB image (height x width x 3) where the nearest point wins each pixel.

    ``point_size`` 2 or 3 grows points in screen space (fills the gaps of a close-up); ``shade`` darkens
    far points so depth reads at a glance; ``hidden`` lists layer indices not to draw.
    """
    background = np.array(BACKGROUND, np.uint8)
    points, owner = scene.points, scene.owner
    if points.shape[0] == 0 or width <= 0 or height <= 0:
        return np.broadcast_to(background, (max(height, 0), max(width, 0), 3)).copy()
    if hidden:
        keep = ~np.isin(owner, list(hidden))
        points, owner = points[keep], owner[keep]
    # Rotate column by column: a BLAS matmul on N x 3 is slower, and its threads fight the GUI's.
    r = camera.rotation().astype(np.float32)
    origin = camera.position().astype(np.float32)
    x, y, z = (points[:, i] - origin[i] for i in range(3))
    depth = r[2, 0] * x + r[2, 1] * y + r[2, 2] * z
    focal = np.float32(camera.focal(height))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = focal / depth
        u = (r[0, 0] * x + r[0, 1] * y + r[0, 2] * z) * scale + np.float32(width / 2.0)
        v = (r[1, 0] * x + r[1, 1] * y + r[1, 2] * z) * scale + np.float32(height / 2.0)
    inside = (depth > NEAR) & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    index = np.flatnonzero(inside)
    if index.size == 0:
        return np.broadcast_to(background, (height, width, 3)).copy()
    depth, owner = depth[index], owner[index]
    pixel = v[index].astype(np.int32) * width + u[index].astype(np.int32)
    # Later layers win ties with the same point in an earlier layer (a filter's output over the original).
    key = depth * (1.0 - owner.astype(np.float32) * np.float32(1e-6))
    zbuffer = np.full(width * height, np.inf, np.float32)
    np.minimum.at(zbuffer, pixel, key)
    win = np.flatnonzero(key <= zbuffer[pixel])
    pixel, owner, depth = pixel[win], owner[win], depth[win]
    palette = np.array([layer_colour(i) for i in range(int(owner.max()) + 1)], np.float32)
    colours = palette[owner]
    if shade:
        near, far = np.percentile(depth[:: max(1, depth.size // 5000)], [2, 98])
        span = max(float(far - near), 1e-6)
        colours *= (1.0 - 0.55 * np.clip((depth - near) / span, 0.0, 1.0))[:, None]
    # Each pixel holds the index of its point's colour; the last row of the table is the background.
    table = np.vstack([colours.astype(np.uint8), background[None, :]])
    owner_image = np.full(width * height, table.shape[0] - 1, np.int32)
    owner_image[pixel] = np.arange(pixel.size, dtype=np.int32)
    if point_size > 1:
        _grow(owner_image.reshape(height, width), zbuffer.reshape(height, width), point_size)
    return table[owner_image].reshape(height, width, 3)


def _grow(owner_image: np.ndarray, zbuffer: np.ndarray, size: int) -> None:
    """Screen-space splatting: an empty pixel takes the nearest point drawn up to ``size - 1`` pixels
    up or left of it, so each point covers a size x size square without drawing the cloud again."""
    empty = ~np.isfinite(zbuffer)
    best = zbuffer.copy()
    source_owner, source_depth = owner_image.copy(), zbuffer
    for dy in range(size):
        for dx in range(size):
            if dx == 0 and dy == 0:
                continue
            h, w = zbuffer.shape
            shifted = source_depth[: h - dy, : w - dx]
            target_best = best[dy:, dx:]
            take = empty[dy:, dx:] & (shifted < target_best)
            target_best[take] = shifted[take]
            owner_image[dy:, dx:][take] = source_owner[: h - dy, : w - dx][take]


def camera_points(camera: OrbitCamera, points: np.ndarray) -> np.ndarray:
    """World points (M x 3) in the camera's frame: x right, y down, z forward (the depth)."""
    return (np.asarray(points, dtype=np.float64) - camera.position()) @ camera.rotation().T


def pixel_point(camera: OrbitCamera, u: float, v: float, width: int, height: int, depth: float) -> np.ndarray:
    """The world point seen at widget pixel (u, v) at ``depth`` metres along the view axis."""
    focal = camera.focal(height)
    local = np.array([(u - width / 2.0) / focal * depth, (v - height / 2.0) / focal * depth, depth])
    return camera.position() + camera.rotation().T @ local


def pick(
    camera: OrbitCamera, points: np.ndarray, u: float, v: float, width: int, height: int, radius: float = 6.0
) -> np.ndarray | None:
    """The nearest point drawn within ``radius`` pixels of (u, v), or None: what the user points at, so a zoom
    or a pan can keep it under the cursor. Large clouds are sampled (every point of a 640x480 cloud is
    checked; beyond about a million, a regular subset) to stay under a few milliseconds."""
    if points.shape[0] == 0:
        return None
    sample = points[:: max(1, points.shape[0] // 1_000_000)]
    local = (sample - camera.position().astype(np.float32)) @ camera.rotation().T.astype(np.float32)
    depth = local[:, 2]
    focal = np.float32(camera.focal(height))
    with np.errstate(divide="ignore", invalid="ignore"):
        du = local[:, 0] * focal / depth + np.float32(width / 2.0 - u)
        dv = local[:, 1] * focal / depth + np.float32(height / 2.0 - v)
    near = np.flatnonzero((depth > NEAR) & (du * du + dv * dv <= radius * radius))
    if near.size == 0:
        return None
    return sample[near[np.argmin(depth[near])]].astype(np.float64)


def fit_distance(camera: OrbitCamera, bounds: tuple[np.ndarray, np.ndarray], aspect: float) -> float:
    """How far from the box's centre the camera must be, looking from any direction, to see the whole box."""
    low, high = bounds
    radius = max(float(np.linalg.norm((high - low) / 2.0)), 1e-3)
    half_fov = min(camera.fov_y / 2.0, math.atan(math.tan(camera.fov_y / 2.0) * max(aspect, 1e-3)))
    return 1.05 * radius / math.sin(half_fov)


def frame_bounds(camera: OrbitCamera, bounds: tuple[np.ndarray, np.ndarray] | None, aspect: float) -> None:
    """Centre the box and move just far enough to see it, keeping the direction the user looks from: the
    "fit to detections" and "fit to cloud" actions (the reset view also turns back to the sensor's)."""
    if bounds is None:
        return
    low, high = (np.asarray(b, dtype=np.float64) for b in bounds)
    camera.target = (low + high) / 2.0
    camera.distance = fit_distance(camera, (low, high), aspect)


def rotate_about(camera: OrbitCamera, d_yaw: float, d_pitch: float, pivot: np.ndarray) -> None:
    """Turn the camera around ``pivot`` (e.g. the detections' centre) instead of its target: the pivot keeps
    its place on screen while everything turns around it."""
    local = camera.rotation() @ (np.asarray(pivot, dtype=np.float64) - camera.position())
    camera.rotate(d_yaw, d_pitch)
    rotation = camera.rotation()
    position = pivot - rotation.T @ local
    camera.target = position + camera.distance * rotation[2]


def zoom_toward(camera: OrbitCamera, factor: float, point: np.ndarray) -> None:
    """Scale the camera's position and target about ``point`` by ``factor`` (< 1 comes closer): the point
    stays under the same pixel, as a map zooms toward the cursor."""
    new_distance = camera.distance * factor
    if not 1e-3 <= new_distance <= 1e4:
        return
    point = np.asarray(point, dtype=np.float64)
    camera.target = point + (camera.target - point) * factor
    camera.distance = float(new_distance)


def nice_step(extent: float) -> float:
    """A round grid spacing (1, 2 or 5 times a power of ten) giving about ten cells across ``extent``."""
    raw = max(extent, 1e-3) / 10.0
    power = 10.0 ** math.floor(math.log10(raw))
    for multiple in (1.0, 2.0, 5.0, 10.0):
        if raw <= multiple * power:
            return multiple * power
    return 10.0 * power


def ground_grid(bounds: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, float]:
    """Segments (K x 2 x 3) of a square grid under the cloud: in the x-z plane (the sensor's y points down)
    at the cloud's lowest level, in round steps; and the step in metres."""
    if bounds is None:
        low, high = np.array([-1.0, 0.0, 0.0]), np.array([1.0, 0.5, 2.0])
    else:
        low, high = bounds
    step = nice_step(float(max(high[0] - low[0], high[2] - low[2])))
    x0, x1 = math.floor(low[0] / step) - 1, math.ceil(high[0] / step) + 1
    z0, z1 = math.floor(min(low[2], 0.0) / step), math.ceil(high[2] / step) + 1
    y = float(high[1])
    segments = [[(i * step, y, z0 * step), (i * step, y, z1 * step)] for i in range(x0, x1 + 1)]
    segments += [[(x0 * step, y, k * step), (x1 * step, y, k * step)] for k in range(z0, z1 + 1)]
    return np.asarray(segments, dtype=np.float64), step


def clip_segment(camera: OrbitCamera, a: np.ndarray, b: np.ndarray, width: int, height: int) -> (
    tuple[tuple[float, float], tuple[float, float]] | None
):
    """Widget coordinates of the part of world segment a-b in front of the camera (None: all behind), so
    grid lines passing beside or behind the viewer are drawn correctly."""
    local = camera_points(camera, np.vstack([a, b]))
    za, zb = local[0, 2], local[1, 2]
    limit = 10 * NEAR
    if za <= limit and zb <= limit:
        return None
    if za <= limit or zb <= limit:
        t = (limit - za) / (zb - za)
        cut = local[0] + t * (local[1] - local[0])
        if za <= limit:
            local[0] = cut
        else:
            local[1] = cut
    focal = camera.focal(height)
    uv = local[:, :2] * (focal / local[:, 2:3]) + (width / 2.0, height / 2.0)
    return (float(uv[0, 0]), float(uv[0, 1])), (float(uv[1, 0]), float(uv[1, 1]))
