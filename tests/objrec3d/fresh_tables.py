"""Fresh table scenes for the small-and-far recall tests, written apart from ``objrec3d.demo``.

The detector's defaults were tuned on ``objrec3d.demo``'s scenes; a test that measures recall on the scenes
that tuned it measures the tuning. These scenes share no code with the demo: their own camera placement,
ray casting, noise and artefacts, and they are used by tests only (never by a benchmark or objrec-tune).

What makes them hard, as a real depth camera on a robot sees a table from 0.6 to 3 m:
- depth noise of 1.5 mm x z^2 (sigma, along the ray; 13.5 mm at 3 m);
- flying pixels: at a depth jump, half the edge pixels return a depth between the object and what is behind;
- cylinders standing and lying (axis along the table, any yaw), spheres, and boxes (clutter, never an object);
- returns missing at grazing angles and at random.

Every point carries the index of the object it shows (-1: table, box, flying pixel or nothing), so a test
counts each object's visible points; flying pixels belong to no object.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from objrec3d.cloud import PointCloud

WIDTH, HEIGHT, FOCAL = 640, 480, 525.0
NOISE_AT_ONE_METRE = 0.0015  # sigma = this x z^2
FLYING_SHARE = 0.5  # of the pixels at a depth jump


@dataclass(frozen=True)
class FreshObject:
    """One object in the camera frame (``axis`` None for a sphere; ``height`` a cylinder's length)."""

    shape: str
    center: np.ndarray
    radius: float
    axis: np.ndarray | None = None
    height: float = 0.0


@dataclass
class FreshScene:
    cloud: PointCloud
    objects: list[FreshObject]
    labels: np.ndarray  # per point: object index, -1 for anything else
    distance: float  # camera to the middle of the table's objects, metres


def _sphere_depth(origin: np.ndarray, rays: np.ndarray, center: np.ndarray, radius: float) -> np.ndarray:
    rel = origin - center
    b = rays @ rel
    c = rel @ rel - radius * radius
    a = np.einsum("ij,ij->i", rays, rays)
    disc = b * b - a * c
    out = np.full(rays.shape[0], np.inf)
    hit = disc >= 0
    t = (-b[hit] - np.sqrt(disc[hit])) / a[hit]
    out[hit] = np.where(t > 0, t, np.inf)
    return out


def _cylinder_depth(origin: np.ndarray, rays: np.ndarray, center: np.ndarray, axis: np.ndarray, radius: float,
                    length: float) -> np.ndarray:
    rel = origin - center
    ray_across = rays - np.outer(rays @ axis, axis)
    rel_across = rel - (rel @ axis) * axis
    a = np.einsum("ij,ij->i", ray_across, ray_across)
    b = ray_across @ rel_across
    c = rel_across @ rel_across - radius * radius
    disc = b * b - a * c
    out = np.full(rays.shape[0], np.inf)
    hit = (disc >= 0) & (a > 1e-12)
    t = (-b[hit] - np.sqrt(disc[hit])) / a[hit]
    along = rel @ axis + t * (rays[hit] @ axis)
    out[hit] = np.where((t > 0) & (np.abs(along) <= length / 2), t, np.inf)
    for end in (-0.5, 0.5):  # the flat ends
        cap = center + end * length * axis
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((cap - origin) @ axis) / (rays @ axis)
        point = origin + t[:, None] * rays
        inside = (t > 0) & (np.einsum("ij,ij->i", point - cap, point - cap) <= radius * radius)
        out = np.where(inside & (t < out), t, out)
    return out


def _box_depth(origin: np.ndarray, rays: np.ndarray, center: np.ndarray, yaw: float, half: np.ndarray) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    to_box = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    o = to_box @ (origin - center)
    d = rays @ to_box.T
    with np.errstate(divide="ignore", invalid="ignore"):
        low, high = (-half - o) / d, (half - o) / d
    enter = np.nanmax(np.minimum(low, high), axis=1)
    leave = np.nanmin(np.maximum(low, high), axis=1)
    return np.where((leave >= enter) & (enter > 0), enter, np.inf)


def _place(rng: np.random.Generator, spread: float, taken: list[tuple[float, float, float]], reach: float
           ) -> tuple[float, float] | None:
    for _ in range(50):
        x, y = rng.uniform(-spread, spread), rng.uniform(-0.6 * spread, 0.6 * spread)
        if all(math.hypot(x - tx, y - ty) > reach + tr + 0.02 for tx, ty, tr in taken):
            taken.append((x, y, reach))
            return x, y
    return None


def fresh_table_scene(seed: int) -> FreshScene:
    """One scene: a camera 0.6-3 m from a table, 25-50 degrees from above, with 3-5 objects and 0-2 boxes."""
    rng = np.random.default_rng([24, seed])
    distance = float(rng.uniform(0.6, 3.0))
    pitch, heading = math.radians(rng.uniform(25.0, 50.0)), rng.uniform(0.0, 2.0 * math.pi)
    eye = distance * np.array([math.cos(pitch) * math.sin(heading), -math.cos(pitch) * math.cos(heading),
                               math.sin(pitch)])
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    to_camera = np.stack([right, down, forward])  # rows: camera axes in table coordinates (z up)
    v, u = np.mgrid[0:HEIGHT, 0:WIDTH]
    rays_camera = np.stack([(u - 319.5) / FOCAL, (v - 239.5) / FOCAL, np.ones((HEIGHT, WIDTH))], axis=-1)
    rays = rays_camera.reshape(-1, 3) @ to_camera  # table coordinates; parameter = depth along camera z

    with np.errstate(divide="ignore", invalid="ignore"):
        table = -eye[2] / rays[:, 2]
    spot = eye + table[:, None] * rays
    table = np.where((table > 0) & (np.abs(spot[:, 0]) < 1.0) & (np.abs(spot[:, 1]) < 0.75), table, np.inf)
    depths, owners = [table], [-1]
    objects_table: list[tuple[str, np.ndarray, float, np.ndarray | None, float]] = []
    taken: list[tuple[float, float, float]] = []
    spread = min(0.12 + 0.1 * distance, 0.35)
    for _ in range(int(rng.integers(3, 6))):
        kind = rng.choice(["standing", "lying", "sphere"])
        radius = float(rng.uniform(0.02, 0.05 if kind != "sphere" else 0.06))
        if kind == "sphere":
            where = _place(rng, spread, taken, radius)
            if where is None:
                continue
            center = np.array([*where, radius])
            depths.append(_sphere_depth(eye, rays, center, radius))
            objects_table.append(("sphere", center, radius, None, 2 * radius))
        else:
            length = float(rng.uniform(max(0.06, 2.0 * radius), 0.2))
            if kind == "standing":
                axis, reach = np.array([0.0, 0.0, 1.0]), radius
                lift = length / 2
            else:
                yaw = rng.uniform(0.0, math.pi)
                axis, reach = np.array([math.cos(yaw), math.sin(yaw), 0.0]), math.hypot(length / 2, radius)
                lift = radius
            where = _place(rng, spread, taken, reach)
            if where is None:
                continue
            center = np.array([*where, lift])
            depths.append(_cylinder_depth(eye, rays, center, axis, radius, length))
            objects_table.append(("cylinder", center, radius, axis, length))
        owners.append(len(objects_table) - 1)
    for _ in range(int(rng.integers(0, 3))):
        half = rng.uniform([0.02, 0.02, 0.02], [0.07, 0.05, 0.08])
        where = _place(rng, spread, taken, float(np.hypot(half[0], half[1])))
        if where is not None:
            depths.append(_box_depth(eye, rays, np.array([*where, half[2]]), rng.uniform(0, math.pi), half))
            owners.append(-1)

    stack = np.stack(depths)
    nearest = np.argmin(stack, axis=0)
    depth = stack[nearest, np.arange(rays.shape[0])]
    labels = np.asarray(owners)[nearest]
    labels[~np.isfinite(depth)] = -1
    cloud_depth, flying = _sense(rng, depth.reshape(HEIGHT, WIDTH), rays_camera)
    points = (rays_camera * cloud_depth[..., None]).reshape(-1, 3)
    labels[~np.isfinite(points[:, 0]) | flying.reshape(-1)] = -1
    objects = []
    for shape, center, radius, axis, length in objects_table:
        c = to_camera @ (center - eye)
        a = None if axis is None else to_camera @ axis
        if a is not None and a @ (-c) < 0:
            a = -a
        objects.append(FreshObject(shape, c, radius, a, length))
    cloud = PointCloud(points.astype(np.float32), None, WIDTH, HEIGHT)
    return FreshScene(cloud, objects, labels, distance)


def _sense(rng: np.random.Generator, depth: np.ndarray, rays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The measured depth image (flying pixels at jumps, noise 1.5 mm x z^2, grazing and random dropouts) and
    where the flying pixels are."""
    measured = depth.copy()
    finite = np.isfinite(depth)
    # Grazing returns: the incidence from the true depth image's gradients.
    points = rays * np.where(finite, depth, np.nan)[..., None]
    du = np.zeros_like(points)
    dv = np.zeros_like(points)
    du[:, 1:-1] = points[:, 2:] - points[:, :-2]
    dv[1:-1] = points[2:] - points[:-2]
    normal = np.cross(du, dv)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs(np.einsum("hwi,hwi->hw", normal, points)) / (
            np.linalg.norm(normal, axis=-1) * np.linalg.norm(points, axis=-1))
    grazing = np.nan_to_num(cos, nan=1.0) < 0.1
    # Flying pixels: a pixel next to a farther one (a jump of more than 2 % of the depth, or to nothing) takes,
    # half the time, a depth between its own and its neighbour's.
    flying = np.zeros_like(finite)
    for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
        other = np.roll(depth, shift, axis=axis)
        far = np.where(np.isfinite(other), other, depth + 0.3)
        with np.errstate(invalid="ignore"):  # inf - inf where neither pixel sees anything
            jump = finite & (far - depth > np.maximum(0.02 * depth, 0.01))
            chosen = jump & ~flying & (rng.random(depth.shape) < FLYING_SHARE)
            mix = rng.uniform(0.1, 0.9, depth.shape)
            measured = np.where(chosen, depth + mix * (far - depth), measured)
        flying |= chosen
    noise = rng.normal(0.0, 1.0, depth.shape) * NOISE_AT_ONE_METRE * measured**2
    measured = measured + np.where(finite, noise, 0.0)
    missing = ~finite | grazing | (rng.random(depth.shape) < 0.01)
    return np.where(missing, np.nan, measured), flying & ~missing
