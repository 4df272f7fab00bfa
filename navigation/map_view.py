"""A picture of part of an occupancy map: which cells it shows, at what scale, and where a world point lands.

The patrol's run picture and the inspection picture both draw routes, robots and objects over a map. Both crop
the map to what matters, scale it to the picture and convert metres to pixels; with one class doing that, a
point lands on the same pixel in both and a fix to the scaling (a large map scaled down, not drawn at a cell per
pixel) reaches both.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .costmap_filters import blend_overlay
from .geometry import Pose2D
from .maps import OccupancyMap


class MapView:
    """The cells ``cols`` x ``rows`` (half-open, grid row 0 at the bottom, clipped to the map) of ``occ_map`` as
    a BGR picture whose longer side is at most ``max_side`` pixels (a small map is scaled up by a whole factor,
    a large one down) and at least ``min_side`` (an animation to project)."""

    def __init__(self, occ_map: OccupancyMap, cols: tuple[int, int], rows: tuple[int, int], max_side: int,
                 min_side: int = 0) -> None:
        self.map = occ_map
        self.c0, self.c1 = max(0, int(cols[0])), min(occ_map.width, int(cols[1]))
        self.r0, self.r1 = max(0, int(rows[0])), min(occ_map.height, int(rows[1]))
        crop = occ_map.to_image()[occ_map.height - self.r1:occ_map.height - self.r0, self.c0:self.c1]
        longest = max(crop.shape)
        # A map larger than the picture is scaled down (a 5000x5000 map made 75 MB frames, 300 of them a video)
        self.scale: float = max(1, max_side // longest) if longest <= max_side else max_side / longest
        if longest * self.scale < min_side:
            self.scale = min_side / longest
        grey = cv2.resize(crop, None, fx=self.scale, fy=self.scale,
                          interpolation=cv2.INTER_NEAREST if self.scale >= 1 else cv2.INTER_AREA)
        #: The map's picture (free white, occupied black, unknown grey); drawing goes on a copy or on this.
        self.image = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
        self.px_per_m = self.scale / occ_map.resolution

    @classmethod
    def of_known(cls, occ_map: OccupancyMap, max_side: int, margin: int = 4) -> MapView:
        """The known part of the map (every cell that is not unknown) with ``margin`` cells around it."""
        known = np.argwhere(occ_map.data >= 0)
        if known.size == 0:
            return cls(occ_map, (0, occ_map.width), (0, occ_map.height), max_side)
        (r0, c0), (r1, c1) = known.min(axis=0), known.max(axis=0) + 1
        return cls(occ_map, (c0 - margin, c1 + margin), (r0 - margin, r1 + margin), max_side)

    def tint(self, zones: np.ndarray) -> None:
        """Blend a zone layer (BGRA over the map's cells, row 0 at the bottom) over the picture."""
        layer = zones[self.r0:self.r1, self.c0:self.c1][::-1]
        layer = cv2.resize(layer, (self.image.shape[1], self.image.shape[0]), interpolation=cv2.INTER_NEAREST)
        self.image = blend_overlay(self.image, layer)

    def px(self, x: float, y: float) -> tuple[int, int]:
        """The pixel of the world point (x, y), metres."""
        gx, gy = self.map.world_to_grid(x, y)
        return (round((gx - self.c0) * self.scale), round((self.r1 - gy) * self.scale))

    def px_array(self, xy: np.ndarray) -> np.ndarray:
        """Pixels of many world points at once (N x 2 in, N x 2 int32 out)."""
        m = self.map
        dx, dy = xy[:, 0] - m.origin.x, xy[:, 1] - m.origin.y
        c, s = math.cos(m.origin.yaw), math.sin(m.origin.yaw)
        gx, gy = (dx * c + dy * s) / m.resolution, (-dx * s + dy * c) / m.resolution
        return np.stack([np.rint((gx - self.c0) * self.scale), np.rint((self.r1 - gy) * self.scale)],
                        axis=1).astype(np.int32)

    def heading(self, pose: Pose2D, length_m: float) -> tuple[int, int]:
        """The pixel ``length_m`` ahead of ``pose``: the tip of its heading mark."""
        yaw = self.map.yaw_to_grid(pose.yaw)
        gx, gy = self.map.world_to_grid(pose.x, pose.y)
        return (round((gx + math.cos(yaw) * length_m / self.map.resolution - self.c0) * self.scale),
                round((self.r1 - gy - math.sin(yaw) * length_m / self.map.resolution) * self.scale))
