"""One object on a table, as a depth camera sees it: a box (sharp or with rounded vertical edges) or a cylinder.

For the cylinder acceptance checks: a flat-sided object must give no cylinder, a real one at the small and
far limits must still give one. The scene reuses the fresh table scenes' ray casting and sensor model
(``fresh_tables``: 1.5 mm x z^2 depth noise, flying pixels, grazing and random dropouts), and the table's
points are dropped by their true label, so the detector sees the object alone whatever plane removal does.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from objrec3d.cloud import PointCloud

from .fresh_tables import FOCAL, HEIGHT, WIDTH, _box_depth, _cylinder_depth, _sense

PITCH_DEGREES = 35.0  # the camera looks down at the table as a robot's does


def _camera(distance: float, heading: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The eye (table coordinates, z up), the rows of the camera axes, and the rays per pixel in both frames."""
    pitch = math.radians(PITCH_DEGREES)
    eye = distance * np.array([math.cos(pitch) * math.sin(heading), -math.cos(pitch) * math.cos(heading),
                               math.sin(pitch)])
    eye[2] += 0.05  # aimed at the object's middle, not the table's surface
    forward = -(eye - [0.0, 0.0, 0.05]) / np.linalg.norm(eye - [0.0, 0.0, 0.05])
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    to_camera = np.stack([right, down, forward])
    v, u = np.mgrid[0:HEIGHT, 0:WIDTH]
    rays_camera = np.stack([(u - 319.5) / FOCAL, (v - 239.5) / FOCAL, np.ones((HEIGHT, WIDTH))], axis=-1)
    return eye, to_camera, rays_camera, rays_camera.reshape(-1, 3) @ to_camera


def _render(seed: int, distance: float, heading: float, object_depth: Callable[[np.ndarray, np.ndarray], np.ndarray]
            ) -> PointCloud:
    eye, _, rays_camera, rays = _camera(distance, heading)
    with np.errstate(divide="ignore", invalid="ignore"):
        table = -eye[2] / rays[:, 2]
    table = np.where(table > 0, table, np.inf)
    thing = object_depth(eye, rays)
    depth = np.minimum(table, thing)
    on_object = thing < table
    rng = np.random.default_rng([25, seed])
    measured, flying = _sense(rng, depth.reshape(HEIGHT, WIDTH), rays_camera)
    points = (rays_camera * measured[..., None]).reshape(-1, 3)
    keep = on_object | flying.reshape(-1)  # the table dropped; flying pixels at the object's edge stay
    points[~keep] = np.nan
    return PointCloud(points.astype(np.float32), None, WIDTH, HEIGHT)


def box_scene(seed: int, distance: float, half: tuple[float, float, float], corner_radius: float = 0.0,
              yaw_degrees: float = 30.0) -> PointCloud:
    """A box of half sizes ``half`` (x, y, z; standing on the table) at ``distance`` metres, its vertical edges
    rounded to ``corner_radius`` (0: sharp), turned by ``yaw_degrees``."""
    hx, hy, hz = half
    yaw = math.radians(yaw_degrees)
    c, s = math.cos(yaw), math.sin(yaw)
    rc = min(corner_radius, hx, hy)
    center = np.array([0.0, 0.0, hz])

    def depth(eye: np.ndarray, rays: np.ndarray) -> np.ndarray:
        parts = [_box_depth(eye, rays, center, yaw, np.array([hx, hy - rc, hz])),
                 _box_depth(eye, rays, center, yaw, np.array([hx - rc, hy, hz]))]
        if rc > 0:
            for sx in (-1, 1):
                for sy in (-1, 1):
                    local = np.array([sx * (hx - rc), sy * (hy - rc)])
                    corner = np.array([c * local[0] - s * local[1], s * local[0] + c * local[1], hz])
                    parts.append(_cylinder_depth(eye, rays, corner, np.array([0.0, 0.0, 1.0]), rc, 2 * hz))
        return np.min(np.stack(parts), axis=0)

    return _render(seed, distance, math.radians(20.0 + 37.0 * seed), depth)


def cylinder_scene(seed: int, distance: float, radius: float, length: float, lying: bool = False) -> PointCloud:
    """A cylinder standing (or lying, axis along the table) on the table at ``distance`` metres."""
    axis = np.array([math.cos(0.7 * seed), math.sin(0.7 * seed), 0.0]) if lying else np.array([0.0, 0.0, 1.0])
    center = np.array([0.0, 0.0, radius if lying else length / 2])

    def depth(eye: np.ndarray, rays: np.ndarray) -> np.ndarray:
        return _cylinder_depth(eye, rays, center, axis, radius, length)

    return _render(seed, distance, math.radians(10.0 + 41.0 * seed), depth)
