"""A simulated laser scan, cast through the same obstacles the robot collides with.

The TurtleBot 2 has no laser; its depth camera is turned into a narrow fake scan. The defaults follow a
Stage model of that scan (58 degree field of view, 640 beams, 6 m). Rays are marched in half-cell steps,
all beams at once with NumPy, so a scan costs a few milliseconds and is computed only when asked for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .costmap import ObstacleField
from .geometry import Pose2D


@dataclass(frozen=True)
class LaserParams:
    fov: float = math.radians(58.0)
    beams: int = 640
    range_min: float = 0.05
    range_max: float = 6.0
    noise: float = 0.0


@dataclass
class LaserScan:
    """Ranges (metres, ``inf`` where nothing was hit within range) for beams from ``angle_min`` upward."""

    angle_min: float
    angle_increment: float
    ranges: np.ndarray
    range_min: float
    range_max: float

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges))


def cast_scan(field: ObstacleField, pose: Pose2D, params: LaserParams | None = None,
              rng: np.random.Generator | None = None) -> LaserScan:
    """Ranges seen from ``pose``; a beam stops at the first obstacle cell it enters."""
    p = params or LaserParams()
    n = max(1, p.beams)
    inc = p.fov / (n - 1) if n > 1 else 0.0
    angle_min = -p.fov / 2.0 if n > 1 else 0.0
    step = field.resolution / 2.0
    dists = np.arange(p.range_min, p.range_max + step, step)
    angles = pose.yaw + angle_min + inc * np.arange(n)
    # Points along every beam, expressed in the grid frame (the map origin may be rotated).
    m = field.map
    gx0, gy0 = m.world_to_grid(pose.x, pose.y)
    grid_angles = angles - m.origin.yaw
    cols = np.floor(gx0 + np.outer(np.cos(grid_angles), dists) / m.resolution).astype(np.int64) + 1
    rows = np.floor(gy0 + np.outer(np.sin(grid_angles), dists) / m.resolution).astype(np.int64) + 1
    outside = (cols < 0) | (cols >= field.width) | (rows < 0) | (rows >= field.height)
    hit = outside.copy()
    inside = ~outside
    hit[inside] = field.obstacle[rows[inside], cols[inside]]
    any_hit = hit.any(axis=1)
    first = np.argmax(hit, axis=1)
    ranges = np.where(any_hit, dists[first], np.inf)
    if p.noise > 0:
        gen = rng or np.random.default_rng(0)
        finite = np.isfinite(ranges)
        ranges[finite] += gen.normal(0.0, p.noise, int(finite.sum()))
        ranges[finite] = np.clip(ranges[finite], p.range_min, p.range_max)
    return LaserScan(angle_min, inc, ranges, p.range_min, p.range_max)
