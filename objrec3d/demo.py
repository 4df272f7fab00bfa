"""The synthetic demo scene: an organized 640 x 480 cloud from a virtual depth camera, with ground truth.

A table top seen from above at an angle, a cylinder, a sphere and some boxes (clutter) on it, and a wall
behind; every pixel's ray is intersected analytically with those surfaces. Sensor noise grows with the
square of the depth (the Kinect model of Nguyen et al. 2012), and returns go missing at random, at grazing
angles and in small blobs, as on a real sensor. The same seed always gives the same scene.

Coordinates: the camera frame (x right, y down, z forward, metres), the frame of the cloud and of every
ground-truth value. Cylinder axes in the truth follow the detector's sign convention (toward the sensor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .cloud import PointCloud

WIDTH, HEIGHT = 640, 480
FX = FY = 525.0
CX, CY = 319.5, 239.5


@dataclass(frozen=True)
class DemoShape:
    """One ground-truth shape in the camera frame. ``axis`` is None for a sphere."""

    shape: str
    center: np.ndarray
    radius: float
    axis: np.ndarray | None = None
    height: float = 0.0


@dataclass
class DemoTruth:
    """What the demo scene holds: its shapes, the table plane (``normal . p + offset = 0``, normal toward
    the camera) and the camera intrinsics."""

    shapes: list[DemoShape] = field(default_factory=list)
    table_normal: np.ndarray = field(default_factory=lambda: np.array([0.0, -1.0, 0.0]))
    table_offset: float = 0.0
    intrinsics: tuple[float, float, float, float] = (FX, FY, CX, CY)

    def of_shape(self, shape: str) -> list[DemoShape]:
        return [s for s in self.shapes if s.shape == shape]


@dataclass
class SceneOptions:
    """What varies between scenes; ``random_scene`` draws these from ranges."""

    camera_height: float = 0.75  # above the table, metres
    camera_distance: float = 0.85  # horizontal distance to the scene centre
    cylinder_radius: float = 0.04
    cylinder_height: float = 0.12
    cylinder_tilt: float = 0.0  # degrees from upright; 90 lies on the table
    cylinder_position: tuple[float, float] = (-0.12, 0.0)  # on the table, metres (x right, y away)
    cylinder_yaw: float = 0.0  # degrees, direction of the tilt
    sphere_radius: float = 0.06
    sphere_position: tuple[float, float] = (0.14, 0.02)
    boxes: int = 3
    noise: float = 1.0  # factor on the sensor noise model
    dropout: float = 0.02  # share of returns missing at random
    include_cylinder: bool = True
    include_sphere: bool = True


def _camera_pose(options: SceneOptions) -> tuple[np.ndarray, np.ndarray]:
    """World (table frame: z up, table at z=0) to camera: rotation R (world->camera) and camera position."""
    eye = np.array([0.0, -options.camera_distance, options.camera_height])
    target = np.array([0.0, 0.0, 0.05])
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    return np.stack([right, down, forward]), eye  # rows: camera axes in world coordinates


def _rays() -> np.ndarray:
    v, u = np.mgrid[0:HEIGHT, 0:WIDTH]
    rays = np.stack([(u - CX) / FX, (v - CY) / FY, np.ones_like(u, dtype=float)], axis=-1).reshape(-1, 3)
    return rays  # z component 1: the ray parameter is the depth


def _hit_plane(o: np.ndarray, d: np.ndarray, point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    denom = d @ normal
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((point - o) @ normal) / denom
    t[~(t > 0)] = np.inf
    return t


def _hit_sphere(o: np.ndarray, d: np.ndarray, center: np.ndarray, radius: float) -> np.ndarray:
    oc = o - center
    a = (d * d).sum(axis=1)
    b = 2.0 * (d @ oc)
    c = oc @ oc - radius * radius
    disc = b * b - 4 * a * c
    t = np.full(d.shape[0], np.inf)
    ok = disc >= 0
    root = (-b[ok] - np.sqrt(disc[ok])) / (2 * a[ok])
    root[root <= 0] = np.inf
    t[ok] = root
    return t


def _hit_cylinder(o: np.ndarray, d: np.ndarray, center: np.ndarray, axis: np.ndarray, radius: float,
                  height: float) -> np.ndarray:
    """Nearest hit with a closed cylinder (side and both caps)."""
    oc = o - center
    dd = d - np.outer(d @ axis, axis)
    od = oc - (oc @ axis) * axis
    a = (dd * dd).sum(axis=1)
    b = 2.0 * (dd @ od)
    c = od @ od - radius * radius
    disc = b * b - 4 * a * c
    t = np.full(d.shape[0], np.inf)
    ok = (disc >= 0) & (a > 1e-12)
    side = (-b[ok] - np.sqrt(disc[ok])) / (2 * a[ok])
    along = oc @ axis + side * (d[ok] @ axis)
    side[(side <= 0) | (np.abs(along) > height / 2)] = np.inf
    t[ok] = side
    for sign in (-1.0, 1.0):  # caps
        cap = center + sign * axis * height / 2
        tc = _hit_plane(o, d, cap, axis)
        hit = o + tc[:, None] * d
        rel = hit - cap
        inside = np.isfinite(tc) & ((rel * rel).sum(axis=1) <= radius * radius)
        t = np.where(inside & (tc < t), tc, t)
    return t


def _hit_box(o: np.ndarray, d: np.ndarray, center: np.ndarray, rotation: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Slab test for an oriented box (rotation columns: the box axes in world)."""
    lo = rotation.T @ (o - center)
    ld = d @ rotation
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - lo) / ld
        t2 = (half - lo) / ld
    near, far = np.minimum(t1, t2), np.maximum(t1, t2)
    # fmax/fmin skip the NaN of a ray parallel to a slab, as nanmax/nanmin do, at a fraction of the cost
    tmin = np.fmax(np.fmax(near[:, 0], near[:, 1]), near[:, 2])
    tmax = np.fmin(np.fmin(far[:, 0], far[:, 1]), far[:, 2])
    t = np.where((tmax >= tmin) & (tmin > 0), tmin, np.inf)
    return t


def _tilted_axis(tilt_deg: float, yaw_deg: float) -> np.ndarray:
    tilt, yaw = math.radians(tilt_deg), math.radians(yaw_deg)
    return np.array([math.sin(tilt) * math.cos(yaw), math.sin(tilt) * math.sin(yaw), math.cos(tilt)])


def render_scene(options: SceneOptions, rng: np.random.Generator) -> tuple[PointCloud, DemoTruth]:
    """Ray-cast one scene; ``rng`` draws the clutter, the noise and the missing returns."""
    rot, eye = _camera_pose(options)
    d = _rays() @ rot  # ray directions in world (camera z = 1 -> depth parameter)
    o = eye
    surfaces: list[tuple[np.ndarray, tuple[int, int, int]]] = []
    # The table: a 1.6 m x 1.2 m top centred ahead of the camera; a wall 1.5 m behind it.
    t_table = _hit_plane(o, d, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    hit = o + t_table[:, None] * d
    t_table[(np.abs(hit[:, 0]) > 0.8) | (np.abs(hit[:, 1]) > 0.6)] = np.inf
    surfaces.append((t_table, (150, 120, 90)))
    surfaces.append((_hit_plane(o, d, np.array([0.0, 1.5, 0.0]), np.array([0.0, -1.0, 0.0])), (200, 200, 190)))
    shapes_world = []
    taken: list[tuple[float, float, float]] = []
    if options.include_cylinder:
        axis = _tilted_axis(options.cylinder_tilt, options.cylinder_yaw)
        r, h = options.cylinder_radius, options.cylinder_height
        # Rest on the table: the lowest point of the closed cylinder touches z = 0.
        lift = 0.5 * h * abs(axis[2]) + r * math.sqrt(max(0.0, 1 - axis[2] ** 2))
        center = np.array([*options.cylinder_position, lift])
        surfaces.append((_hit_cylinder(o, d, center, axis, r, h), (200, 40, 40)))
        shapes_world.append(("cylinder", center, r, axis, h))
        taken.append((*options.cylinder_position, max(r, 0.5 * h * math.sqrt(max(0.0, 1 - axis[2] ** 2)) + r)))
    if options.include_sphere:
        r = options.sphere_radius
        center = np.array([*options.sphere_position, r])
        surfaces.append((_hit_sphere(o, d, center, r), (40, 60, 200)))
        shapes_world.append(("sphere", center, r, None, 2 * r))
        taken.append((*options.sphere_position, r))
    for _ in range(options.boxes):
        for _attempt in range(30):
            half = rng.uniform([0.02, 0.02, 0.02], [0.08, 0.06, 0.1])
            xy = rng.uniform([-0.45, -0.25], [0.45, 0.35])
            reach = float(np.hypot(half[0], half[1]))
            if all(math.hypot(xy[0] - x, xy[1] - y) > reach + rr + 0.03 for x, y, rr in taken):
                break
        else:
            continue
        taken.append((xy[0], xy[1], reach))
        yaw = rng.uniform(0, math.pi)
        box_rot = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
        color = tuple(int(c) for c in rng.integers(60, 230, 3))
        surfaces.append((_hit_box(o, d, np.array([xy[0], xy[1], half[2]]), box_rot, half), color))
    depths = np.stack([s[0] for s in surfaces])
    nearest = np.argmin(depths, axis=0)
    t = depths[nearest, np.arange(d.shape[0])]
    colors = np.array([s[1] for s in surfaces], dtype=np.float64)[nearest]

    cloud = _sense(o, d, t, rot, colors, options.noise, options.dropout, rng)

    truth = DemoTruth()
    truth.table_normal = rot @ np.array([0.0, 0.0, 1.0])
    truth.table_offset = float(-truth.table_normal @ (rot @ (np.zeros(3) - eye)))
    for shape, center, r, axis, h in shapes_world:
        c_cam = rot @ (center - eye)
        a_cam = None
        if axis is not None:
            a_cam = rot @ axis
            if a_cam @ (-c_cam) < 0:  # the detector's convention: toward the sensor
                a_cam = -a_cam
        truth.shapes.append(DemoShape(shape, c_cam, r, a_cam, h))
    return cloud, truth


def _sense(o: np.ndarray, d: np.ndarray, t: np.ndarray, rot: np.ndarray, colors: np.ndarray, noise: float,
           dropout: float, rng: np.random.Generator, depth_noise: float | None = None) -> PointCloud:
    """What the depth camera returns for ray hits at depth ``t``: shading, depth noise growing with the square
    of the depth, returns missing at random, at grazing angles and in blobs. ``depth_noise``: sigma = this x
    z^2 (x ``noise``) instead of the Kinect model's 1.2 mm + 1.9 mm x (z - 0.4)^2."""
    # Incidence: estimate the surface normal from the depth image to drop grazing returns.
    hit_world = o + t[:, None] * d
    grid = np.where(np.isfinite(t), 1.0, np.nan)[:, None] * (hit_world - o) @ rot.T  # camera frame
    g = grid.reshape(HEIGHT, WIDTH, 3)
    du = np.zeros_like(g)
    dv = np.zeros_like(g)
    du[:, 1:-1] = g[:, 2:] - g[:, :-2]
    dv[1:-1] = g[2:] - g[:-2]
    normal = np.cross(du, dv).reshape(-1, 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        view = grid / np.linalg.norm(grid, axis=1, keepdims=True)
        incidence = np.abs((normal * view).sum(axis=1))
    shade = np.where(np.isfinite(incidence), 0.45 + 0.55 * np.nan_to_num(incidence), 1.0)
    colors = np.clip(colors * shade[:, None] + rng.normal(0, 4, colors.shape), 0, 255)

    depth = grid[:, 2]
    sigma = (noise * (0.0012 + 0.0019 * (depth - 0.4) ** 2) if depth_noise is None
             else noise * depth_noise * np.nan_to_num(depth, nan=0.0) ** 2)
    factor = 1.0 + rng.normal(0.0, 1.0, depth.shape) * sigma / np.where(depth > 0, depth, 1.0)
    points = grid * factor[:, None]
    missing = ~np.isfinite(depth) | (rng.random(depth.shape) < dropout)
    missing |= np.nan_to_num(incidence, nan=0.0) < 0.12  # grazing angles return nothing
    # Blobs of missing returns (specular spots, absorbing patches).
    blob_mask = np.zeros((HEIGHT, WIDTH), dtype=bool)
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    for _ in range(int(rng.integers(2, 6))):
        cy, cx, rad = rng.uniform(0, HEIGHT), rng.uniform(0, WIDTH), rng.uniform(3, 10)
        blob_mask |= (yy - cy) ** 2 + (xx - cx) ** 2 < rad * rad
    missing |= blob_mask.reshape(-1)
    points[missing] = np.nan
    cloud = PointCloud(points.astype(np.float32), colors.astype(np.uint8), WIDTH, HEIGHT)

    return cloud


def _flying_pixels(depth: np.ndarray, rng: np.random.Generator, share: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Depths with flying pixels: a pixel next to a farther one (a jump of over 2 % of its depth, or to nothing)
    returns, with probability ``share``, a depth between its own and its neighbour's, as a time-of-flight or
    stereo camera mixes the two at an edge. Returns the new depths (flat) and where the flying pixels are."""
    grid = depth.reshape(HEIGHT, WIDTH)
    out = grid.copy()
    finite = np.isfinite(grid)
    flying = np.zeros_like(finite)
    for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
        other = np.roll(grid, shift, axis=axis)
        far = np.where(np.isfinite(other), other, grid + 0.3)
        with np.errstate(invalid="ignore"):  # inf - inf where neither pixel sees anything
            jump = finite & ~flying & (far - grid > np.maximum(0.02 * grid, 0.01))
        chosen = jump & (rng.random(grid.shape) < share)
        with np.errstate(invalid="ignore"):
            out = np.where(chosen, grid + rng.uniform(0.1, 0.9, grid.shape) * (far - grid), out)
        flying |= chosen
    return out.reshape(-1), flying.reshape(-1)


def random_options(rng: np.random.Generator, *, hard: bool = True) -> SceneOptions:
    """Scene options drawn from the ranges the tests cover: radii, poses, noise and clutter."""
    cylinder_x = rng.uniform(-0.25, -0.08)
    return SceneOptions(
        camera_height=rng.uniform(0.55, 0.9),
        camera_distance=rng.uniform(0.6, 1.0),
        cylinder_radius=rng.uniform(0.025, 0.08),
        cylinder_height=rng.uniform(0.1, 0.25),
        cylinder_tilt=float(rng.choice([0.0, rng.uniform(0, 40), 90.0])) if hard else 0.0,
        cylinder_yaw=rng.uniform(0, 180),
        cylinder_position=(cylinder_x, rng.uniform(-0.1, 0.15)),
        sphere_radius=rng.uniform(0.03, 0.09),
        sphere_position=(rng.uniform(0.1, 0.25), rng.uniform(-0.1, 0.15)),
        boxes=int(rng.integers(0, 5)) if hard else 2,
        noise=rng.uniform(0.5, 1.5) if hard else 1.0,
        dropout=rng.uniform(0.0, 0.05),
    )


def demo_scene(seed: int = 0, frame: int = 0) -> tuple[PointCloud, DemoTruth]:
    """Frame ``frame`` of the demo: a fixed layout from ``seed``; the sphere rolls slowly across the table and
    the noise is new in every frame."""
    layout = np.random.default_rng(seed)
    options = random_options(layout, hard=False) if seed else SceneOptions()
    x, y = options.sphere_position
    swing = 0.05 * math.sin(frame * 0.2)
    options.sphere_position = (x + swing, y)
    return render_scene(options, np.random.default_rng([seed, frame]))


def shape_scene(rng: np.random.Generator, distance: float, *, cylinders: int = 2, spheres: int = 1,
                radii: tuple[float, float] = (0.012, 0.08), noise: float = 1.0, hard: bool = False
                ) -> tuple[PointCloud, DemoTruth, np.ndarray]:
    """A table seen from ``distance`` metres (to the middle of the objects, 35 degrees from above) with
    upright cylinders and spheres of random radii side by side on it, for accuracy tests at any range.

    Returns the cloud, the truth and, per point, the index of the truth shape it shows (-1: table or nothing),
    so a test can count each object's visible points after any filter. Nothing lies beyond the table.

    ``hard``: as a robot's camera sees a table: depth noise 1.5 mm x z^2, flying pixels (half of
    the pixels at a depth jump return a depth between the object and what is behind it; labelled -1), every
    other cylinder lying on the table (axis along it, pointing away from the camera within 25 degrees) and
    one or two boxes nearer the camera (clutter, not in the truth). The same ``rng`` gives the same scene;
    without ``hard`` the draws and the scenes are those of before."""
    pitch = math.radians(35.0)
    options = SceneOptions(camera_height=distance * math.sin(pitch), camera_distance=distance * math.cos(pitch),
                           noise=noise, dropout=0.02)
    rot, eye = _camera_pose(options)
    d = _rays() @ rot
    t_table = _hit_plane(eye, d, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    hit = eye + t_table[:, None] * d
    t_table[(np.abs(hit[:, 0]) > 0.8) | (np.abs(hit[:, 1]) > 0.6)] = np.inf  # a 1.6 x 1.2 m table, no wall
    surfaces = [(t_table, (150, 120, 90))]
    kinds = ["cylinder"] * cylinders + ["sphere"] * spheres
    order = rng.permutation(len(kinds))
    spread = min(0.12 * distance, 0.25)  # side by side across the view, a little apart in depth
    shapes_world = []
    x = -0.5 * spread * (len(kinds) - 1)
    lying = False
    for k in order:
        r = float(rng.uniform(*radii))
        center_xy = (x + rng.uniform(-0.02, 0.02), rng.uniform(-0.05, 0.05))
        x += spread
        if kinds[k] == "cylinder":
            h = float(rng.uniform(2.0, 4.0) * r + 0.03)
            center = np.array([*center_xy, 0.5 * h])
            axis = np.array([0.0, 0.0, 1.0])
            if hard and lying:  # every other cylinder lies on the table, pointing away within 25 degrees
                yaw = float(rng.uniform(-math.radians(25.0), math.radians(25.0)))  # (its slot is across the view)
                axis = np.array([math.sin(yaw), math.cos(yaw), 0.0])
                center = np.array([*center_xy, r])
            lying = not lying
            surfaces.append((_hit_cylinder(eye, d, center, axis, r, h), (200, 40, 40)))
            shapes_world.append(("cylinder", center, r, axis, h))
        else:
            center = np.array([*center_xy, r])
            surfaces.append((_hit_sphere(eye, d, center, r), (40, 60, 200)))
            shapes_world.append(("sphere", center, r, None, 2 * r))
    boxes = 0
    if hard:  # clutter beside the row of objects, nearer the camera: boxes are no object
        for _ in range(int(rng.integers(1, 3))):
            half = rng.uniform([0.02, 0.02, 0.02], [0.06, 0.04, 0.07])
            where = np.array([rng.uniform(-spread, spread), -0.12 - 0.5 * spread * rng.random(), half[2]])
            yaw = rng.uniform(0.0, math.pi)
            box_rot = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
            surfaces.append((_hit_box(eye, d, where, box_rot, half), (120, 160, 90)))
            boxes += 1
    depths = np.stack([s[0] for s in surfaces])
    nearest = np.argmin(depths, axis=0)
    t = depths[nearest, np.arange(d.shape[0])]
    colors = np.array([s[1] for s in surfaces], dtype=np.float64)[nearest]
    labels = np.where(np.isfinite(t), nearest - 1, -1)
    labels[labels >= len(shapes_world)] = -1  # the boxes
    if hard:
        t, flying = _flying_pixels(t, rng)
        labels[flying] = -1
    cloud = _sense(eye, d, t, rot, colors, noise, 0.02, rng, depth_noise=0.0015 if hard else None)
    truth = DemoTruth()
    truth.table_normal = rot @ np.array([0.0, 0.0, 1.0])
    truth.table_offset = float(-truth.table_normal @ (rot @ (np.zeros(3) - eye)))
    for shape, center, r, axis, h in shapes_world:
        c_cam = rot @ (center - eye)
        a_cam = None if axis is None else rot @ axis
        if a_cam is not None and a_cam @ (-c_cam) < 0:
            a_cam = -a_cam
        truth.shapes.append(DemoShape(shape, c_cam, r, a_cam, h))
    return cloud, truth, labels
