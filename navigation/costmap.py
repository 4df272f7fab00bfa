"""What the robot can bump into, and how far every cell is from it.

One obstacle definition serves both the simulated world (collisions, laser) and the planner, so a
path the planner finds is never through something the simulator treats as solid. The distance field is
computed once per map with OpenCV, which makes every later clearance question a table look-up.
"""

from __future__ import annotations

import math

import numpy as np

from .grid_distance import distance_to_zero
from .maps import OccupancyMap


def shared_list(values: np.ndarray) -> list[float]:
    """``values.ravel().tolist()``, but equal values share one Python object.

    The planner and the clearance look-ups keep per-cell lists for speed; ``tolist`` makes a new float per
    cell (32 bytes), while a map holds few distinct distances and costs: shared, a cell costs the 8 bytes of
    its reference, which keeps a huge map's planner within memory.
    """
    unique, inverse = np.unique(values.ravel(), return_inverse=True)
    objects = np.empty(len(unique), dtype=object)
    objects[:] = unique.tolist()
    return objects[inverse.ravel()].tolist()  # type: ignore[no-any-return]


class ObstacleField:
    """Obstacle cells of a map and, for every cell, the distance to the nearest one.

    The grid is padded with one ring of obstacle cells, so the edge of the map is a wall and neighbour
    look-ups never leave the array. ``dist[j, i]`` (metres) is measured between cell centres of the
    padded grid; cell (i, j) of the map is ``(i + 1, j + 1)`` here.
    """

    def __init__(self, occ_map: OccupancyMap, lethal_threshold: int = 65, unknown_is_obstacle: bool = True) -> None:
        self.map = occ_map
        self.resolution = occ_map.resolution
        data = occ_map.data
        obstacle = data >= lethal_threshold
        if unknown_is_obstacle:
            obstacle |= data < 0
        padded = np.ones((data.shape[0] + 2, data.shape[1] + 2), dtype=bool)
        padded[1:-1, 1:-1] = obstacle
        self.obstacle = padded
        free = (~padded).astype(np.uint8)
        self.dist = distance_to_zero(free)
        self.dist *= self.resolution
        self.height, self.width = padded.shape
        self._dist_list = shared_list(self.dist)
        # A centre more than this far (in metres) from every obstacle centre is clear of any robot of
        # radius r when dist - slack >= r: the robot's offset in its cell plus an obstacle's half-diagonal.
        self._slack = self.resolution * math.sqrt(2.0)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """Padded-grid cell (column, row) of a world point."""
        gx, gy = self.map.world_to_grid(x, y)
        return math.floor(gx) + 1, math.floor(gy) + 1

    def inside(self, i: int, j: int) -> bool:
        return 0 <= i < self.width and 0 <= j < self.height

    def clearance(self, x: float, y: float) -> float:
        """Approximate distance from a point to the nearest obstacle surface (0 outside the map)."""
        i, j = self.cell(x, y)
        if not self.inside(i, j):
            return 0.0
        return max(0.0, self._dist_list[j * self.width + i] - 0.5 * self.resolution)

    def collides(self, x: float, y: float, radius: float) -> bool:
        """Whether a disc of ``radius`` at (x, y) overlaps an obstacle cell (exact near obstacles)."""
        gx, gy = self.map.world_to_grid(x, y)
        i, j = math.floor(gx) + 1, math.floor(gy) + 1
        if not (0 <= i < self.width and 0 <= j < self.height):
            return True
        if self._dist_list[j * self.width + i] - self._slack >= radius:
            return False
        r_cells = radius / self.resolution
        i0, i1 = max(0, math.floor(gx + 1 - r_cells)), min(self.width - 1, math.floor(gx + 1 + r_cells))
        j0, j1 = max(0, math.floor(gy + 1 - r_cells)), min(self.height - 1, math.floor(gy + 1 + r_cells))
        window = self.obstacle[j0:j1 + 1, i0:i1 + 1]
        if not window.any():
            return False
        jj, ii = np.nonzero(window)
        # Distance from the point to each obstacle square [i, i+1) x [j, j+1) in padded grid units.
        px, py = gx + 1.0, gy + 1.0
        dx = np.maximum(np.maximum((ii + i0) - px, px - (ii + i0 + 1)), 0.0)
        dy = np.maximum(np.maximum((jj + j0) - py, py - (jj + j0 + 1)), 0.0)
        return bool(np.any(dx * dx + dy * dy < r_cells * r_cells))
