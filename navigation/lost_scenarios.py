"""The lost-robot scenarios, shared by the tests and ``benchmarks/bench_nav_lost.py``.

* :func:`lost_room`: a 7 m x 4 m room whose blocks make no two places look alike, not even after a half turn
  of the room (a symmetric room has two equally good answers to "where am I?", and global localisation may
  pick the wrong one), with :data:`LOST_ROOM_GOALS`.
* :data:`SYMMETRIC_ROOM_BLOCKS`: the same room with blocks that a half turn about its centre maps onto each other,
  so every place has a twin that looks the same (:func:`twin`): after a kidnap the map cannot tell the robot
  where it is, and it must say so rather than drive on a guess.
* :data:`CORRIDOR_LENGTH`, :data:`CORRIDOR_GOALS`, :data:`CORRIDOR_KIDNAP`: a 30 m corridor 2 m wide with bare
  walls (:func:`navigation.people_scenarios.corridor_map`); the robot patrols between its ends and is carried to
  its middle, 15 m from either end, farther than the laser's 6 m: every place along the middle looks the same,
  and the robot must say it cannot tell where along the corridor it is.
* :func:`box_between_pillars`: the lesson's unmapped 0.5 m box, centred between the TurtleBot3 world's middle
  pillar and its neighbour along +x, about 0.15 m from each.
* :func:`spread_goals`: goal poses spread over the largest free region by farthest-point sampling.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .costmap import ObstacleField
from .geometry import Pose2D, wrap_angle
from .maps import FREE, OCCUPIED, OccupancyMap
from .planner import Planner
from .world import WorldObject

RESOLUTION = 0.05
LOST_ROOM_BLOCKS = ((2.0, 2.5, 2.6, 3.0), (4.2, 0.5, 4.6, 1.6), (0.6, 1.9, 1.6, 2.3), (6.3, 0.5, 6.9, 0.9))
LOST_ROOM_GOALS = (Pose2D(1.0, 1.0, 0.0), Pose2D(6.0, 3.0, 1.5), Pose2D(3.5, 1.2, 3.0), Pose2D(1.0, 3.2, -1.5))
#: Where the kidnap tests carry the robot: a corner no other place in the room resembles.
LOST_ROOM_KIDNAP = Pose2D(1.2, 3.3, 0.0)
#: Blocks placed in pairs by a half turn about the room's centre (3.5, 2.0), and one across the centre.
SYMMETRIC_ROOM_BLOCKS = ((1.0, 0.5, 1.6, 1.2), (5.4, 2.8, 6.0, 3.5), (3.0, 1.8, 4.0, 2.2))
SYMMETRIC_ROOM_GOALS = (Pose2D(1.0, 2.0, 0.0), Pose2D(3.5, 3.3, 0.0), Pose2D(6.0, 2.0, 3.0), Pose2D(3.5, 0.8, 3.0))
SYMMETRIC_ROOM_KIDNAP = Pose2D(2.2, 3.2, 0.5)
CORRIDOR_LENGTH, CORRIDOR_WIDTH = 30.0, 2.0
CORRIDOR_GOALS = (Pose2D(2.0, 1.0, 0.0), Pose2D(28.0, 1.0, math.pi))
#: Facing a side wall in the middle: amcl, which believes the robot faces along the corridor, notices at once.
CORRIDOR_KIDNAP = Pose2D(15.0, 1.0, math.pi / 2)
PILLAR_MAX = 0.5  # metres: an obstacle blob smaller than this on both axes is a pillar
BOX_SIZE = 0.5


def lost_room(blocks: tuple[tuple[float, float, float, float], ...] = LOST_ROOM_BLOCKS, width: float = 7.0,
              height: float = 4.0) -> OccupancyMap:
    """A walled room of ``width`` x ``height`` metres with rectangular ``blocks`` (x0, y0, x1, y1)."""
    data = np.full((round(height / RESOLUTION), round(width / RESOLUTION)), FREE, np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = OCCUPIED
    for x0, y0, x1, y1 in blocks:
        data[round(y0 / RESOLUTION):round(y1 / RESOLUTION), round(x0 / RESOLUTION):round(x1 / RESOLUTION)] = OCCUPIED
    return OccupancyMap(data, RESOLUTION, Pose2D(0.0, 0.0, 0.0))


def twin(pose: Pose2D, width: float = 7.0, height: float = 4.0) -> Pose2D:
    """The place that looks like ``pose`` in a room symmetric under a half turn about its centre."""
    return Pose2D(width - pose.x, height - pose.y, wrap_angle(pose.yaw + math.pi))


def pillars(occ_map: OccupancyMap) -> list[tuple[float, float]]:
    """Centres of the map's small obstacle blobs (the TurtleBot3 world's pillars)."""
    field = ObstacleField(occ_map)
    _, _, stats, centres = cv2.connectedComponentsWithStats(field.obstacle.astype(np.uint8), connectivity=8)
    return [occ_map.grid_to_world(cx - 0.5, cy - 0.5) for (cx, cy), st in zip(centres[1:], stats[1:], strict=True)
            if max(st[2], st[3]) * occ_map.resolution < PILLAR_MAX]


def box_between_pillars(occ_map: OccupancyMap) -> WorldObject:
    """A 0.5 m box centred between the pillar nearest the origin and its neighbour along +x."""
    small = pillars(occ_map)
    if len(small) < 2:
        raise ValueError("the map has fewer than two pillars")
    middle = min(small, key=lambda p: math.hypot(*p))
    right = min((p for p in small if p[0] > middle[0] + 0.5), key=lambda p: abs(p[1] - middle[1]) + p[0])
    return WorldObject("box", "box", 0.5 * (middle[0] + right[0]), 0.5 * (middle[1] + right[1]),
                       width=BOX_SIZE, depth=BOX_SIZE, height=BOX_SIZE)


def spread_goals(planner: Planner, n: int, seed: int, min_clearance: float = 0.4) -> list[Pose2D]:
    """``n`` poses over the largest free region, each ``min_clearance`` m from any obstacle, farthest first."""
    labels = planner.labels
    counts = np.bincount(labels.ravel())
    counts[0] = 0
    rows, cols = np.nonzero((labels == counts.argmax()) & (planner.clear >= min_clearance))
    m = planner.field.map
    pts = np.array([m.cell_to_world(i - 1, j - 1) for i, j in zip(cols, rows, strict=True)])
    rng = np.random.default_rng(seed)
    chosen = [int(rng.integers(len(pts)))]
    dist = np.hypot(*(pts - pts[chosen[0]]).T)
    for _ in range(n - 1):
        k = int(dist.argmax())
        chosen.append(k)
        dist = np.minimum(dist, np.hypot(*(pts - pts[k]).T))
    return [Pose2D(float(pts[k][0]), float(pts[k][1]), float(rng.uniform(-np.pi, np.pi))) for k in chosen]
