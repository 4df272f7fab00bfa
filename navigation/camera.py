"""A simulated RGB-D camera on the robot (TurtleBot 2's Orbbec Astra by default), fast enough to run live.

It draws what the robot would see: the map's occupied cells extruded into walls, the floor, and the
world's objects and obstacles (:mod:`navigation.world`), as a BGR colour image, a depth image in metres, the
intrinsics and the organized point cloud in the optical frame (x right, y down, z forward). Depth has the
faults that matter to recognition on the real sensor: axial noise growing with the square of the distance,
no return nearer than ``min_range`` or beyond ``max_range``, and returns missing more and more often as the
surface is seen at a grazing angle. Each frame keeps which solid every pixel shows, so it knows its own
ground truth: the objects in view, in the optical frame, with their visible points (:meth:`RGBDFrame.truth`).

The camera is level (no pitch or roll), which makes every image column a vertical plane in the world. So
nothing is traced per pixel in Python: walls are found by one exact 2D march per column through the
occupancy grid (all columns at once, stopping when each has hit), a wall's depth is then constant down its
column and the floor's depth constant along a row; each object is intersected analytically, only inside
the rectangle its bounding box projects to. A 640x480 frame of a room with ten objects takes about 15 ms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .camera_truth import SeenObject, seen_objects
from .costmap import ObstacleField
from .geometry import Pose2D
from .maps import OccupancyMap
from .world import World, WorldObject

#: Cells with these occupancy values are walls, as for the simulator's collisions (unknown is solid too).
LETHAL_THRESHOLD = 65
#: A poster counts as in front of a wall up to this far behind its face (it hangs on it).
POSTER_TOLERANCE = 0.02
#: Objects are clipped this close to the camera (metres along the optical axis).
NEAR_CLIP = 0.02
#: Direction the world is lit from (map frame, towards the light): above, a little from +x and +y.
LIGHT = (0.35, 0.55, 0.76)
#: Crossings examined per step of the wall march (a step covers this many cells along each axis).
MARCH_CHUNK = 48


@dataclass(frozen=True)
class CameraParams:
    """The camera and its mount; defaults follow the Orbbec Astra on a TurtleBot 2.

    - ``width``, ``height`` (pixels), ``hfov_deg``; ``vfov_deg`` None means square pixels (45.15 degrees
      at 640x480).
    - ``min_range``, ``max_range`` (metres of depth): outside them a pixel has colour but no depth.
    - ``mount_x`` (forward), ``mount_y`` (left), ``mount_z`` (height of the optical centre above the
      floor) and ``mount_yaw`` (radians, from the robot's heading); the camera is level.
    - ``noise_k``: the depth noise's standard deviation is ``noise_k * z**2`` (0.0015 gives 1.5 mm at
      1 m, 6 mm at 2 m, 2.4 cm at 4 m, about a structured-light sensor's axial noise).
    - Returns go missing with a probability rising (linearly in the cosine) from 0 at
      ``grazing_start_deg`` to 1 at ``grazing_end_deg`` of the angle between the ray and the surface
      normal: the far floor thins out, walls seen edge-on lose returns.
    - ``draw_distance``: walls farther than this are not drawn (the background shows).
    - ``ambient``: the share of light every surface gets; the rest comes from a fixed direction, so
      faces turned away are darker but keep their hue. ``color_noise``: grey-level noise (standard
      deviation, 0-255 scale) added to the colour image.
    """

    width: int = 640
    height: int = 480
    hfov_deg: float = 58.0
    vfov_deg: float | None = None
    min_range: float = 0.6
    max_range: float = 8.0
    mount_x: float = 0.0
    mount_y: float = 0.0
    mount_z: float = 0.3
    mount_yaw: float = 0.0
    noise_k: float = 0.0015
    grazing_start_deg: float = 80.0
    grazing_end_deg: float = 89.0
    draw_distance: float = 30.0
    ambient: float = 0.55
    color_noise: float = 0.0

    def __post_init__(self) -> None:
        if self.width < 2 or self.height < 2:
            raise ValueError(f"camera image must be at least 2x2 pixels, got {self.width}x{self.height}")
        if not 0.0 < self.hfov_deg < 180.0 or (self.vfov_deg is not None and not 0.0 < self.vfov_deg < 180.0):
            raise ValueError("camera fields of view must lie strictly between 0 and 180 degrees")
        if not 0.0 <= self.min_range < self.max_range:
            raise ValueError(f"need 0 <= min_range < max_range, got {self.min_range} and {self.max_range}")
        if not 0.0 <= self.grazing_start_deg < self.grazing_end_deg <= 90.0:
            raise ValueError("need 0 <= grazing_start_deg < grazing_end_deg <= 90")
        if self.noise_k < 0.0 or self.color_noise < 0.0 or not 0.0 <= self.ambient <= 1.0:
            raise ValueError("noise must be >= 0 and ambient within [0, 1]")

    @property
    def fx(self) -> float:
        return 0.5 * self.width / math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def fy(self) -> float:
        if self.vfov_deg is None:
            return self.fx
        return 0.5 * self.height / math.tan(math.radians(self.vfov_deg) / 2.0)

    @property
    def cx(self) -> float:
        return 0.5 * (self.width - 1)

    @property
    def cy(self) -> float:
        return 0.5 * (self.height - 1)


@dataclass(frozen=True)
class CameraPose:
    """The optical centre in the map frame (z up from the floor) and the heading the camera looks along."""

    x: float
    y: float
    z: float
    yaw: float

    @property
    def rotation(self) -> np.ndarray:
        """3x3 matrix whose columns are the optical axes (x right, y down, z forward) in the map frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[s, 0.0, c], [-c, 0.0, s], [0.0, -1.0, 0.0]])

    def camera_to_map(self, points: np.ndarray) -> np.ndarray:
        """Optical-frame points (..., 3) to the map frame (x, y on the floor, z up); NaN stays NaN."""
        p = np.asarray(points, dtype=np.float64)
        return p @ self.rotation.T + np.array([self.x, self.y, self.z])

    def map_to_camera(self, points: np.ndarray) -> np.ndarray:
        """Map-frame points (..., 3) to the optical frame."""
        p = np.asarray(points, dtype=np.float64)
        return (p - np.array([self.x, self.y, self.z])) @ self.rotation


@dataclass(eq=False)
class RGBDFrame:
    """One camera frame: colour (BGR uint8), depth (float32 metres, NaN where no return), intrinsics, and
    the organized point cloud (float32, optical frame, NaN where no return), with the poses it was taken at.
    """

    color: np.ndarray
    depth: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    points: np.ndarray
    camera_pose: CameraPose
    robot_pose: Pose2D
    t: float = 0.0
    #: Which solid each pixel shows (H x W int16: an index into ``solids``, -1 for walls, floor and background).
    object_ids: np.ndarray | None = None
    #: What was drawn, where it stood at ``t``: the world's objects first (``object_count`` of them), then obstacles.
    solids: tuple[WorldObject, ...] = ()
    object_count: int = 0

    @property
    def K(self) -> np.ndarray:  # noqa: N802 - the usual name of the intrinsic matrix
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def width(self) -> int:
        return int(self.depth.shape[1])

    @property
    def height(self) -> int:
        return int(self.depth.shape[0])

    def camera_to_map(self, points: np.ndarray) -> np.ndarray:
        """Optical-frame points (N x 3, or any ... x 3) to the map frame (z up)."""
        return self.camera_pose.camera_to_map(points)

    def map_to_camera(self, points: np.ndarray) -> np.ndarray:
        return self.camera_pose.map_to_camera(points)

    def project(self, points_map: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (N x 2, u right, v down) and optical depth (N) of map-frame points; pixels of
        points behind the camera are NaN."""
        p = np.atleast_2d(self.map_to_camera(points_map))
        z = p[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([self.cx + self.fx * p[:, 0] / z, self.cy + self.fy * p[:, 1] / z], axis=1)
        uv[z <= 0.0] = np.nan
        return uv, z

    def pixel_ray(self, u: float, v: float) -> tuple[np.ndarray, np.ndarray]:
        """Origin and unit direction, in the map frame, of the ray through pixel (u, v)."""
        d = np.array([(u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0])
        direction = self.camera_pose.rotation @ (d / np.linalg.norm(d))
        return np.array([self.camera_pose.x, self.camera_pose.y, self.camera_pose.z]), direction

    def pixel_rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit map-frame directions (N x 3) of the rays through pixels (N x 2, u, v)."""
        px = np.atleast_2d(np.asarray(pixels, dtype=np.float64))
        d = np.stack([(px[:, 0] - self.cx) / self.fx, (px[:, 1] - self.cy) / self.fy, np.ones(len(px))], axis=1)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d @ self.camera_pose.rotation.T

    def map_points(self) -> np.ndarray:
        """The organized cloud in the map frame (H x W x 3, NaN where no return)."""
        return self.camera_to_map(self.points)

    def truth(self, obstacles: bool = False) -> list[SeenObject]:
        """The world's objects this frame shows, in the optical frame, with their visible point counts: the
        frame's ground truth (:mod:`navigation.camera_truth`); with ``obstacles``, the obstacles too."""
        return seen_objects(self, obstacles)


class _Layer:
    """Depth, viewing cosine and colour being composited (the nearest surface wins).

    Colour is kept as one uint32 per pixel (the bytes B, G, R, 255) so that a pixel is written with one
    store; :meth:`bgr` unpacks it at the end.
    """

    def __init__(self, depth: np.ndarray, cos_view: np.ndarray, color32: np.ndarray) -> None:
        self.depth = depth
        self.cos_view = cos_view
        self.color32 = color32
        self.ids = np.full(depth.shape, -1, np.int16)  # the solid each pixel shows (the frame's truth)

    def bgr(self) -> np.ndarray:
        h, w = self.color32.shape
        return cv2.cvtColor(self.color32.view(np.uint8).reshape(h, w, 4), cv2.COLOR_BGRA2BGR)


def _pack(bgr: np.ndarray) -> np.ndarray:
    """uint8 (..., 3) BGR colours as uint32 (..., ) with the byte layout of :class:`_Layer`."""
    out = np.empty((*bgr.shape[:-1], 4), np.uint8)
    out[..., :3] = bgr
    out[..., 3] = 255
    return out.view(np.uint32)[..., 0]


class RGBDCamera:
    """Renders :class:`RGBDFrame` s of a world seen from a robot pose.

    Deterministic: the randomness comes from a generator made from ``random_seed``, so the same sequence
    of renders gives the same frames. Drawing 600,000 fresh random numbers per frame would cost about a
    quarter of the frame time, so the camera draws a table of four frames' worth of independent samples once and
    reads each frame's noise (and dropout draws) from a window at a random offset in it: a pixel's noise
    is independent from frame to frame, as the sensor's is. The map's wall grid is cached while the same
    map is rendered.
    """

    #: Noise tables hold this many frames' worth of samples.
    TABLE_FRAMES = 4

    def __init__(self, params: CameraParams | None = None, random_seed: int = 0) -> None:
        self.params = p = params or CameraParams()
        self.fx, self.fy, self.cx, self.cy = p.fx, p.fy, p.cx, p.cy
        w, h = p.width, p.height
        # Normalized image coordinates of pixel centres: the optical ray of (u, v) is (xn[u], yn[v], 1).
        self.xn = ((np.arange(w) - self.cx) / self.fx).astype(np.float64)
        self.yn = ((np.arange(h) - self.cy) / self.fy).astype(np.float64)
        self._xn32 = self.xn.astype(np.float32)
        self._yn32 = self.yn.astype(np.float32)
        # 1 / |ray| per pixel: turns a dot product with an unnormalized ray into a cosine.
        self._inv_norm = (1.0 / np.sqrt(1.0 + self.xn[None, :] ** 2 + self.yn[:, None] ** 2)).astype(np.float32)
        self._cos_start = math.cos(math.radians(p.grazing_start_deg))
        self._cos_end = math.cos(math.radians(p.grazing_end_deg))
        self._columns = np.arange(w, dtype=np.int32)
        self._grid_cache: tuple[OccupancyMap, np.ndarray, np.ndarray] | None = None
        self._pyramids: dict[int, tuple[np.ndarray, list[np.ndarray]]] = {}
        light = np.array(LIGHT)
        self._light = light / np.linalg.norm(light)
        self.reseed(random_seed)

    # -- geometry ------------------------------------------------------------------------------------
    def camera_pose(self, robot_pose: Pose2D) -> CameraPose:
        """Where the optical centre is and where it looks for the robot at ``robot_pose``."""
        p = self.params
        c, s = math.cos(robot_pose.yaw), math.sin(robot_pose.yaw)
        return CameraPose(robot_pose.x + c * p.mount_x - s * p.mount_y, robot_pose.y + s * p.mount_x + c * p.mount_y,
                          p.mount_z, robot_pose.yaw + p.mount_yaw)

    def intrinsics(self) -> tuple[float, float, float, float]:
        return self.fx, self.fy, self.cx, self.cy

    def reseed(self, random_seed: int) -> None:
        """Restart the randomness (the same seed gives the same frames again)."""
        self.rng = np.random.default_rng(random_seed)
        n = self.params.width * self.params.height * self.TABLE_FRAMES
        self._normal_table = self.rng.standard_normal(n, dtype=np.float32)
        self._uniform_table = self.rng.random(n, dtype=np.float32)

    def _window(self, table: np.ndarray) -> np.ndarray:
        n = self.params.width * self.params.height
        offset = int(self.rng.integers(0, len(table) - n + 1))
        return table[offset:offset + n].reshape(self.params.height, self.params.width)

    # -- rendering -----------------------------------------------------------------------------------
    def render(self, world: World | None, occ_map: OccupancyMap | ObstacleField, robot_pose: Pose2D,
               t: float = 0.0) -> RGBDFrame:
        """The frame the camera takes at simulated time ``t`` (moving obstacles are where they are then).

        ``occ_map`` gives the walls: a map (occupied and unknown cells are solid, as the simulator's
        default) or the :class:`~navigation.costmap.ObstacleField` the simulation collides with (then its
        own threshold and extra cells apply).
        """
        p = self.params
        cam = self.camera_pose(robot_pose)
        c, s = math.cos(cam.yaw), math.sin(cam.yaw)
        # Horizontal direction of each column's plane, scaled so that the ray parameter is the depth.
        dx = c + self.xn * s
        dy = s - self.xn * c
        world = world or World()
        wall_s, wall_nx, wall_ny = self._march_walls(occ_map, cam, dx, dy)
        layer = self._base_layer(cam, dx, dy, wall_s, wall_nx, wall_ny, world)
        solids = tuple(world.solids_at(t))
        for index, solid in enumerate(solids):
            self._draw_solid(layer, solid, cam, dx, dy, index)

        depth = layer.depth
        valid = (depth >= p.min_range) & (depth <= p.max_range)
        if self._cos_start > 0.0:
            drop_p = (self._cos_start - layer.cos_view) * np.float32(1.0 / (self._cos_start - self._cos_end))
            valid &= self._window(self._uniform_table) >= drop_p
        if p.noise_k > 0.0:
            noise = self._window(self._normal_table) * np.float32(p.noise_k)
            with np.errstate(invalid="ignore", over="ignore"):
                noise *= depth
                noise *= depth
                depth += noise
        depth = np.where(valid, depth, np.float32(np.nan))
        color = layer.bgr()
        if p.color_noise > 0.0:
            jitter = self._window(self._normal_table)[:, :, None] * np.float32(p.color_noise)
            color = np.clip(color + jitter, 0, 255).astype(np.uint8)
        points = np.empty((*depth.shape, 3), np.float32)
        np.multiply(depth, self._xn32[None, :], out=points[:, :, 0])
        np.multiply(depth, self._yn32[:, None], out=points[:, :, 1])
        points[:, :, 2] = depth
        return RGBDFrame(color, depth, self.fx, self.fy, self.cx, self.cy, points, cam, robot_pose, t, layer.ids,
                         solids, len(world.objects))

    def _wall_grid(self, occ_map: OccupancyMap | ObstacleField) -> tuple[OccupancyMap, np.ndarray]:
        """The map and its solid cells padded with a solid ring, so the edge of the map is a wall (as in
        :class:`~navigation.costmap.ObstacleField`); cached for the map object last seen."""
        if isinstance(occ_map, ObstacleField):
            return occ_map.map, occ_map.obstacle
        cache = self._grid_cache
        if cache is not None and cache[0] is occ_map and cache[1] is occ_map.data:
            return occ_map, cache[2]
        data = occ_map.data
        grid = np.ones((data.shape[0] + 2, data.shape[1] + 2), dtype=bool)
        grid[1:-1, 1:-1] = (data >= LETHAL_THRESHOLD) | (data < 0)
        self._grid_cache = (occ_map, occ_map.data, grid)
        return occ_map, grid

    def _march_walls(self, walls: OccupancyMap | ObstacleField, cam: CameraPose, dx: np.ndarray, dy: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Depth of the first wall in each column (inf beyond ``draw_distance``) and its face normal (map frame).

        Exact grid traversal: the ray's crossings of vertical and of horizontal cell boundaries are
        examined in chunks, only for the columns still unresolved; the first crossing that enters a solid
        cell is the hit.
        """
        occ_map, grid = self._wall_grid(walls)
        res = occ_map.resolution
        co, so = math.cos(occ_map.origin.yaw), math.sin(occ_map.origin.yaw)
        gx, gy = occ_map.world_to_grid(cam.x, cam.y)
        px, py = gx + 1.0, gy + 1.0  # padded grid
        gdx = (dx * co + dy * so) / res  # cells per metre of depth
        gdy = (-dx * so + dy * co) / res
        n = len(dx)
        rows, cols = grid.shape
        i0, j0 = math.floor(px), math.floor(py)
        if not (0 <= i0 < cols and 0 <= j0 < rows) or grid[j0, i0]:
            return np.zeros(n), np.zeros(n), np.zeros(n)
        limit = self.params.draw_distance
        sx = _first_hits(grid, px, py, gdx, gdy, limit)
        sy = _first_hits(grid.T, py, px, gdy, gdx, limit)
        x_face = sx <= sy
        s = np.where(x_face, sx, sy)
        # Normal of the face hit, in the grid frame, facing the camera; then rotated into the map frame.
        gnx = np.where(x_face, -np.sign(gdx), 0.0)
        gny = np.where(x_face, 0.0, -np.sign(gdy))
        return s, gnx * co - gny * so, gnx * so + gny * co

    def _base_layer(self, cam: CameraPose, dx: np.ndarray, dy: np.ndarray, wall_s: np.ndarray, wall_nx: np.ndarray,
                    wall_ny: np.ndarray, world: World) -> _Layer:
        """Floor, walls and background: the floor's depth depends on the row only, a wall's on the column.

        Written with arithmetic on whole images rather than masked selection, which is several times faster.
        """
        p = self.params
        h = cam.z
        yn = self.yn
        finite = np.isfinite(wall_s)
        with np.errstate(divide="ignore", invalid="ignore"):
            floor_s = np.where(yn > 0.0, h / yn, np.inf).astype(np.float32)[:, None]
            wall_top = np.where(finite, (h - world.wall_height) / wall_s, np.inf).astype(np.float32)[None, :]
        above = self._yn32[:, None] < wall_top  # above the wall's top edge (or no wall in the column)
        wall = wall_s.astype(np.float32)[None, :] + above * np.float32(1e30)
        depth = np.minimum(floor_s, wall)  # sky: inf or 1e30, out of range
        on_floor = floor_s < wall
        on_wall = ~(on_floor | above)
        # Viewing cosines: floor normal (0, 0, 1) against ray (dx, dy, -yn): yn / |ray|; a wall: |n . d| / |ray|.
        wall_dot = np.abs(wall_nx * dx + wall_ny * dy).astype(np.float32)[None, :]
        cos_view = on_floor * self._yn32[:, None] + on_wall * wall_dot
        cos_view *= self._inv_norm
        # Colours from a palette: 0 background, 1 floor, 2 + u the wall of column u (each face shaded by the
        # fixed light, so the floor is one shade and each wall face has its own).
        a = p.ambient
        lx, ly, lz = self._light
        wall_shade = a + (1.0 - a) * np.abs(wall_nx * lx + wall_ny * ly)
        palette = np.empty((2 + p.width, 3), np.float32)
        palette[0] = world.background_color
        palette[1] = np.array(world.floor_color, np.float32) * (a + (1.0 - a) * abs(lz))
        palette[2:] = np.array(world.wall_color, np.float32)[None, :] * wall_shade[:, None]
        palette32 = _pack(np.clip(palette, 0, 255).astype(np.uint8))
        index = on_floor.view(np.int8).astype(np.int32)
        index += on_wall * (2 + self._columns)[None, :]
        return _Layer(depth, cos_view, palette32.take(index))

    # -- objects -------------------------------------------------------------------------------------
    def _rect(self, solid: WorldObject, cam: CameraPose) -> tuple[int, int, int, int] | None:
        """Pixel rectangle (v0, v1, u0, u1) covering the solid's bounding box, clipped at the near plane."""
        p = self.params
        if solid.shape in ("cylinder", "sphere"):
            hx = hy = solid.radius
            yaw = 0.0
        elif solid.shape == "box":
            hx, hy, yaw = 0.5 * solid.depth, 0.5 * solid.width, solid.yaw
        else:
            hx, hy, yaw = 0.0, 0.5 * solid.width, solid.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        ground = local @ np.array([[c, s], [-s, c]]) + np.array([solid.x, solid.y])
        corners = np.empty((8, 3))
        corners[:4, :2] = corners[4:, :2] = ground
        corners[:4, 2] = solid.z
        corners[4:, 2] = solid.top
        pc = cam.map_to_camera(corners)
        z = pc[:, 2]
        if np.all(z < NEAR_CLIP):
            return None
        if np.any(z < NEAR_CLIP):
            extra = []
            for i, j in _BOX_EDGES:
                if (z[i] < NEAR_CLIP) != (z[j] < NEAR_CLIP):
                    f = (NEAR_CLIP - z[i]) / (z[j] - z[i])
                    extra.append(pc[i] + f * (pc[j] - pc[i]))
            pc = np.concatenate([pc[z >= NEAR_CLIP], np.array(extra).reshape(-1, 3)])
            z = pc[:, 2]
        u = self.cx + self.fx * pc[:, 0] / z
        v = self.cy + self.fy * pc[:, 1] / z
        u0 = max(0, math.floor(u.min()))
        u1 = min(p.width, math.ceil(u.max()) + 1)
        v0 = max(0, math.floor(v.min()))
        v1 = min(p.height, math.ceil(v.max()) + 1)
        if u0 >= u1 or v0 >= v1:
            return None
        return v0, v1, u0, u1

    def _draw_solid(self, layer: _Layer, solid: WorldObject, cam: CameraPose, dx: np.ndarray, dy: np.ndarray,
                    index: int = -1) -> None:
        rect = self._rect(solid, cam)
        if rect is None:
            return
        v0, v1, u0, u1 = rect
        args = (solid, cam, dx[u0:u1], dy[u0:u1], self.yn[v0:v1], self._light)
        if solid.shape == "cylinder":
            s, dot, shade = _cylinder(*args)
        elif solid.shape == "box":
            s, dot, shade = _box(*args)
        elif solid.shape == "sphere":
            s, dot, shade = _sphere(*args)
        else:
            self._draw_poster(layer, solid, cam, rect, dx[u0:u1], dy[u0:u1], index)
            return
        zbuf = layer.depth[v0:v1, u0:u1]
        mask = s < zbuf
        if not mask.any():
            return
        zbuf[mask] = s[mask]
        layer.ids[v0:v1, u0:u1][mask] = index
        layer.cos_view[v0:v1, u0:u1][mask] = (dot * self._inv_norm[v0:v1, u0:u1])[mask]
        a = self.params.ambient
        shaded = (a + (1.0 - a) * shade[mask])[:, None] * np.array(solid.color, np.float32)
        layer.color32[v0:v1, u0:u1][mask] = _pack(np.clip(shaded, 0, 255).astype(np.uint8))

    def _draw_poster(self, layer: _Layer, solid: WorldObject, cam: CameraPose, rect: tuple[int, int, int, int],
                     dx: np.ndarray, dy: np.ndarray, index: int = -1) -> None:
        """A vertical textured rectangle; its image is sampled from a pyramid level that matches the distance."""
        v0, v1, u0, u1 = rect
        yn = self.yn[v0:v1]
        c, s_ = math.cos(solid.yaw), math.sin(solid.yaw)
        nx, ny = c, s_
        ax, ay = -s_, c  # across the poster: left to right of its picture, seen from the front
        ox, oy = solid.x - cam.x, solid.y - cam.y
        denom = dx * nx + dy * ny
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (ox * nx + oy * ny) / denom
            lateral = (s * dx - ox) * ax + (s * dy - oy) * ay
        col_ok = (s > 0.0) & (np.abs(lateral) <= 0.5 * solid.width) & np.isfinite(s)
        if not col_ok.any():
            return
        s = np.where(col_ok, s, np.inf)
        lateral = np.where(col_ok, lateral, 0.0)
        with np.errstate(invalid="ignore"):
            height = cam.z - yn[:, None] * s[None, :]  # height above the floor where each ray meets the plane
            hit = col_ok[None, :] & (height >= solid.z) & (height <= solid.z + solid.height)
        zbuf = layer.depth[v0:v1, u0:u1]
        s32 = np.broadcast_to(s.astype(np.float32)[None, :], hit.shape)
        mask = hit & (s32 < zbuf + np.float32(POSTER_TOLERANCE))
        if not mask.any():
            return
        zbuf[mask] = s32[mask]
        layer.ids[v0:v1, u0:u1][mask] = index
        dot = np.abs(denom).astype(np.float32)[None, :] * self._inv_norm[v0:v1, u0:u1]
        layer.cos_view[v0:v1, u0:u1][mask] = dot[mask]
        a = self.params.ambient
        light = self._light
        shade = a + (1.0 - a) * abs(nx * light[0] + ny * light[1])
        front = (-ox * nx - oy * ny) > 0.0
        if not front or solid.image is None:
            rgb = np.clip(np.array(solid.color, np.float32) * shade, 0, 255).astype(np.uint8)
            layer.color32[v0:v1, u0:u1][mask] = _pack(rgb)
            return
        image = solid.image
        ih, iw = image.shape[:2]
        texels_per_pixel = iw / solid.width * float(np.median(s[col_ok])) / self.fx
        level = max(0, math.floor(math.log2(max(texels_per_pixel, 1.0))))
        levels = self._pyramid(image, level)
        level = min(level, len(levels) - 1)
        img = levels[level]
        scale_x, scale_y = img.shape[1] / iw, img.shape[0] / ih
        height = np.where(hit, height, solid.z)
        map_x = ((lateral / solid.width + 0.5) * iw * scale_x - 0.5).astype(np.float32)
        map_y = (((solid.z + solid.height - height) / solid.height) * ih * scale_y - 0.5).astype(np.float32)
        map_x = np.ascontiguousarray(np.broadcast_to(map_x[None, :], map_y.shape))
        texture = cv2.remap(img, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if shade < 0.999:
            texture = cv2.convertScaleAbs(texture, alpha=shade)
        texture32 = cv2.cvtColor(texture, cv2.COLOR_BGR2BGRA).view(np.uint32)[:, :, 0]
        layer.color32[v0:v1, u0:u1][mask] = texture32[mask]

    def _pyramid(self, image: np.ndarray, level: int) -> list[np.ndarray]:
        key = id(image)
        cached = self._pyramids.get(key)
        if cached is None or cached[0] is not image:
            cached = (image, [image])
            self._pyramids[key] = cached
        levels = cached[1]
        while len(levels) <= level and min(levels[-1].shape[:2]) >= 2:
            levels.append(cv2.pyrDown(levels[-1]))
        return levels


_BOX_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7))


def _first_hits(grid: np.ndarray, pa: float, pb: float, da: np.ndarray, db: np.ndarray, limit: float) -> np.ndarray:
    """Depth at which each ray p + s d first enters a solid cell through a boundary a = const (inf if none
    within ``limit``). ``grid`` is indexed [b, a]; rays run from (pa, pb) in cell units."""
    n = len(da)
    result = np.full(n, np.inf)
    moving = np.abs(da) > 1e-12
    idx = np.nonzero(moving)[0]
    if idx.size == 0:
        return result
    size_b, size_a = grid.shape
    d_a, d_b = da[idx], db[idx]
    forward = d_a > 0.0
    first = np.where(forward, math.floor(pa) + 1.0, float(math.floor(pa)))  # the first boundary crossed
    step = np.where(forward, 1.0, -1.0)
    t0 = (first - pa) / d_a
    dt = 1.0 / np.abs(d_a)
    k = np.arange(MARCH_CHUNK, dtype=np.float64)
    base = 0
    while idx.size:
        kk = base + k[None, :]
        t = t0[:, None] + kk * dt[:, None]
        boundary = first[:, None] + kk * step[:, None]
        cell_a = (boundary - (~forward)[:, None]).astype(np.int64)  # going backwards enters the cell below
        cell_b = np.floor(pb + t * d_b[:, None]).astype(np.int64)
        np.clip(cell_a, 0, size_a - 1, out=cell_a)
        np.clip(cell_b, 0, size_b - 1, out=cell_b)
        solid = grid[cell_b, cell_a] | (t > limit)
        found = solid.any(axis=1)
        if found.any():
            first_k = np.argmax(solid[found], axis=1)
            hit_t = t[found, first_k]
            result[idx[found]] = np.where(hit_t > limit, np.inf, hit_t)
        keep = ~found
        idx, t0, dt, first, step, forward, d_b = (idx[keep], t0[keep], dt[keep], first[keep], step[keep],
                                                  forward[keep], d_b[keep])
        base += MARCH_CHUNK
    return result


# -- analytic intersections: each returns depth (inf where missed), |normal . ray| (unnormalized ray)
#    and |normal . light| per pixel of the rectangle ----------------------------------------------------------
def _cylinder(solid: WorldObject, cam: CameraPose, dx: np.ndarray, dy: np.ndarray, yn: np.ndarray,
              light: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    fx, fy = cam.x - solid.x, cam.y - solid.y
    r = solid.radius
    a = dx * dx + dy * dy
    b = fx * dx + fy * dy
    c = fx * fx + fy * fy - r * r
    disc = b * b - a * c
    with np.errstate(invalid="ignore"):
        side = (-b - np.sqrt(disc)) / a
    side = np.where((disc >= 0.0) & (side > 0.0) & (c > 0.0), side, np.inf)  # per column
    height = cam.z - yn[:, None] * side[None, :]
    top = solid.z + solid.height
    ok = (height >= solid.z) & (height <= top)
    s = np.where(ok, side[None, :], np.inf)
    finite = np.isfinite(side)
    hx = np.where(finite, fx + side * dx, 0.0) / r
    hy = np.where(finite, fy + side * dy, 0.0) / r
    dot = np.broadcast_to(np.abs(hx * dx + hy * dy)[None, :], s.shape)
    shade = np.broadcast_to(np.abs(hx * light[0] + hy * light[1])[None, :], s.shape)
    for cap in _visible_caps(solid, cam):
        with np.errstate(divide="ignore", invalid="ignore"):
            sc = (cam.z - cap) / yn  # per row; positive only when looking towards the cap
        sc = np.where(sc > 0.0, sc, np.inf)
        qx = fx + sc[:, None] * dx[None, :]
        qy = fy + sc[:, None] * dy[None, :]
        inside = (qx * qx + qy * qy <= r * r) & (sc[:, None] < s)
        if inside.any():
            s = np.where(inside, sc[:, None], s)
            dot = np.where(inside, np.abs(yn)[:, None], dot)
            shade = np.where(inside, abs(light[2]), shade)
    return s.astype(np.float32), np.asarray(dot, np.float32), np.asarray(shade, np.float32)


def _box(solid: WorldObject, cam: CameraPose, dx: np.ndarray, dy: np.ndarray, yn: np.ndarray,
         light: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    c, s_ = math.cos(solid.yaw), math.sin(solid.yaw)
    ox, oy = cam.x - solid.x, cam.y - solid.y
    px, py = c * ox + s_ * oy, -s_ * ox + c * oy  # camera in the box's frame
    ldx, ldy = c * dx + s_ * dy, -s_ * dx + c * dy
    hx, hy = 0.5 * solid.depth, 0.5 * solid.width
    with np.errstate(divide="ignore", invalid="ignore"):
        ex, lx_ = _slab_np(px, ldx, hx)
        ey, ly_ = _slab_np(py, ldy, hy)
    enter = np.maximum(ex, ey)
    leave = np.minimum(lx_, ly_)
    outside = abs(px) > hx or abs(py) > hy
    side = np.where((enter <= leave) & (enter > 0.0) & outside, enter, np.inf)  # per column
    x_face = ex >= ey
    height = cam.z - yn[:, None] * side[None, :]
    top = solid.z + solid.height
    s = np.where((height >= solid.z) & (height <= top), side[None, :], np.inf)
    llx, lly = c * light[0] + s_ * light[1], -s_ * light[0] + c * light[1]
    dot = np.broadcast_to(np.where(x_face, np.abs(ldx), np.abs(ldy))[None, :], s.shape)
    shade = np.broadcast_to(np.where(x_face, abs(llx), abs(lly))[None, :], s.shape)
    for cap in _visible_caps(solid, cam):
        with np.errstate(divide="ignore", invalid="ignore"):
            sc = (cam.z - cap) / yn
        sc = np.where(sc > 0.0, sc, np.inf)
        qx = px + sc[:, None] * ldx[None, :]
        qy = py + sc[:, None] * ldy[None, :]
        inside = (np.abs(qx) <= hx) & (np.abs(qy) <= hy) & (sc[:, None] < s)
        if inside.any():
            s = np.where(inside, sc[:, None], s)
            dot = np.where(inside, np.abs(yn)[:, None], dot)
            shade = np.where(inside, abs(light[2]), shade)
    return s.astype(np.float32), np.asarray(dot, np.float32), np.asarray(shade, np.float32)


def _visible_caps(solid: WorldObject, cam: CameraPose) -> list[float]:
    """Heights of the flat top and bottom the camera can see: the top from above, the bottom from below
    (never a bottom standing on the floor)."""
    top = solid.z + solid.height
    caps = [top] if cam.z > top else []
    if solid.z > 0.0 and cam.z < solid.z:
        caps.append(solid.z)
    return caps


def _slab_np(p: float, d: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    safe = np.where(d == 0.0, 1e-300, d)
    t1 = (-half - p) / safe
    t2 = (half - p) / safe
    return np.minimum(t1, t2), np.maximum(t1, t2)


def _sphere(solid: WorldObject, cam: CameraPose, dx: np.ndarray, dy: np.ndarray, yn: np.ndarray,
            light: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = solid.radius
    fx, fy, fz = cam.x - solid.x, cam.y - solid.y, cam.z - (solid.z + r)
    a = (dx * dx + dy * dy)[None, :] + (yn * yn)[:, None]
    b = (fx * dx + fy * dy)[None, :] - (fz * yn)[:, None]
    c = fx * fx + fy * fy + fz * fz - r * r
    disc = b * b - a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    s = (-b - root) / a
    hit = (disc >= 0.0) & (s > 0.0) & (c > 0.0)
    s = np.where(hit, s, np.inf)
    dot = root / r  # |n . ray| for the unnormalized ray
    with np.errstate(invalid="ignore"):
        nx = (fx + s * dx[None, :]) / r
        ny = (fy + s * dy[None, :]) / r
        nz = (fz - s * yn[:, None]) / r
        shade = np.abs(np.where(hit, nx * light[0] + ny * light[1] + nz * light[2], 0.0))
    return s.astype(np.float32), dot.astype(np.float32), shade.astype(np.float32)
