"""Keepout and speed zones from mask maps in Nav2's costmap-filter format.

Nav2 marks where a robot may not go, or must go slowly, on a second map beside the real one: a map_server YAML
and image (the *mask*) plus a few numbers (its ``CostmapFilterInfo``). The same files work here, without ROS:

- **keepout**: mask cells that are occupied (value 65 or more; black in a ``trinary`` mask) become lethal for
  the planner, inflated like walls, so neither a plan nor the robot following it enters them. The simulated
  world and the laser do not see them: a keepout zone is a rule, not a wall (so amcl is not misled by it).
- **speed**: a mask value ``v`` in 1..100 limits the speed to ``base + multiplier * v``, in percent of the
  controller's maximum speed (Nav2's filter type 1) or in m/s (type 2); 0 and unknown cells set no limit.
  Nav2's tutorial mask is ``mode: scale`` with ``base: 100, multiplier: -1``: the darker, the slower.

A mask may have its own resolution and origin: it is sampled at the centre of every cell of the map the robot
navigates, once, so the planner and the controller look cells up in arrays of the map's own shape.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .geometry import Pose2D
from .maps import UNKNOWN, OccupancyMap, load_map

log = logging.getLogger(__name__)

#: Mask values from which a keepout cell is lethal: the costmap's lethal threshold, as for the map itself.
KEEPOUT_THRESHOLD = 65
#: Nav2's ``CostmapFilterInfo.type`` of the speed filter: percent of the maximum speed, or metres per second.
SPEED_LIMIT_TYPES = ("percent", "absolute")
#: Cells sampled at a time when a mask is laid on the map (bounds the temporaries to a few megabytes).
SAMPLE_BAND_CELLS = 1 << 18


def box_mask(size: tuple[float, float], resolution: float, box: tuple[float, float, float, float],
             value: int) -> OccupancyMap:
    """A mask of ``size`` (metres, origin at 0, 0) holding ``value`` inside ``box`` (x0, y0, x1, y1 in metres)
    and 0 elsewhere: how the exercises' keepout and speed masks are drawn, ready for ``maps.save_map``."""
    data = np.zeros((round(size[1] / resolution), round(size[0] / resolution)), np.int8)
    x0, y0, x1, y1 = (round(v / resolution) for v in box)
    data[y0:y1, x0:x1] = value
    return OccupancyMap(data, resolution, Pose2D(0.0, 0.0, 0.0))


def sample_mask(mask: OccupancyMap, target: OccupancyMap) -> np.ndarray:
    """The mask's value at the centre of every cell of ``target`` (its shape, row 0 at the bottom); unknown
    where the mask does not reach. Done a band of rows at a time, so a map at the cell limit costs the result
    (two bytes a cell) and a band of temporaries, not ten full-size arrays."""
    out = np.full(target.data.shape, UNKNOWN, dtype=np.int16)
    cos_t, sin_t = math.cos(target.origin.yaw), math.sin(target.origin.yaw)
    cos_m, sin_m = math.cos(mask.origin.yaw), math.sin(mask.origin.yaw)
    u = (np.arange(target.width) + 0.5) * target.resolution
    band = max(1, SAMPLE_BAND_CELLS // max(1, target.width))
    for r0 in range(0, target.height, band):
        v = ((np.arange(r0, min(r0 + band, target.height)) + 0.5) * target.resolution)[:, None]
        dx = target.origin.x + u * cos_t - v * sin_t - mask.origin.x
        dy = target.origin.y + u * sin_t + v * cos_t - mask.origin.y
        i = np.floor((dx * cos_m + dy * sin_m) / mask.resolution).astype(np.int64)
        j = np.floor((-dx * sin_m + dy * cos_m) / mask.resolution).astype(np.int64)
        inside = (i >= 0) & (i < mask.width) & (j >= 0) & (j < mask.height)
        rows = out[r0:r0 + len(v)]
        rows[inside] = mask.data[j[inside], i[inside]]
    return out


def keepout_cells(mask: OccupancyMap, target: OccupancyMap) -> np.ndarray:
    """Boolean cells of ``target`` inside a keepout zone of ``mask``."""
    return sample_mask(mask, target) >= KEEPOUT_THRESHOLD


def load_keepout(mask_yaml: str | Path, target: OccupancyMap) -> np.ndarray:
    """Keepout cells of ``target`` from a keepout mask (a map_server YAML); errors name the mask's file."""
    cells = keepout_cells(load_map(mask_yaml), target)
    log.info("keepout mask %s: %d cells of the map kept out", mask_yaml, int(cells.sum()))
    return cells


@dataclass(frozen=True)
class SpeedLimitInfo:
    """How mask values become speed limits (Nav2's ``CostmapFilterInfo`` for the speed filter)."""

    kind: str = "percent"
    base: float = 100.0
    multiplier: float = -1.0

    def limit(self, value: np.ndarray, max_speed: float) -> np.ndarray:
        """Speed limits in m/s for mask values (inf where the value sets none: 0 or unknown)."""
        raw = self.base + self.multiplier * value.astype(np.float64)
        speed = raw / 100.0 * max_speed if self.kind == "percent" else raw
        speed = np.clip(speed, 0.0, max_speed)
        return np.where(value > 0, speed, np.inf)


class SpeedZones:
    """Speed limits over the cells of a map, and the cap they put on a velocity command.

    The cap looks ahead along the heading as far as the robot needs to slow down to the limit (one step plus
    the braking distance at ``acceleration``), so the robot enters a zone already at its speed instead of
    braking inside it.
    """

    def __init__(self, limits: np.ndarray, occ_map: OccupancyMap, acceleration: float) -> None:
        self.limits = limits
        self.map = occ_map
        self.acceleration = acceleration

    @classmethod
    def from_mask(cls, mask: OccupancyMap, target: OccupancyMap, info: SpeedLimitInfo, max_speed: float,
                  acceleration: float) -> SpeedZones:
        return cls(info.limit(sample_mask(mask, target), max_speed), target, acceleration)

    @property
    def empty(self) -> bool:
        return not bool(np.isfinite(self.limits).any())

    def limit_at(self, x: float, y: float) -> float:
        """The speed limit (m/s) at a world point; inf where none applies."""
        i, j = self.map.world_to_cell(x, y)
        return float(self.limits[j, i]) if self.map.in_bounds(i, j) else math.inf

    def cap(self, pose: Pose2D, v: float, w: float, dt: float) -> tuple[float, float]:
        """(v, w) scaled down together (the same arc) so that |v| respects every limit within braking reach."""
        speed = abs(v)
        if speed == 0.0:
            return v, w
        reach = speed * dt + speed * speed / (2.0 * self.acceleration)
        n = max(2, math.ceil(reach / (0.5 * self.map.resolution)) + 1)
        heading = pose.yaw if v > 0.0 else pose.yaw + math.pi
        limit = min(self.limit_at(pose.x + s * math.cos(heading), pose.y + s * math.sin(heading))
                    for s in np.linspace(0.0, reach, n))
        if speed <= limit:
            return v, w
        scale = limit / speed
        return v * scale, w * scale


def load_speed_zones(mask_yaml: str | Path, target: OccupancyMap, info: SpeedLimitInfo, max_speed: float,
                     acceleration: float) -> SpeedZones:
    """Speed zones over ``target`` from a speed mask (a map_server YAML); errors name the mask's file."""
    zones = SpeedZones.from_mask(load_map(mask_yaml), target, info, max_speed, acceleration)
    limited = np.isfinite(zones.limits)
    if limited.any():
        log.info("speed mask %s: %d cells limited, %.2f..%.2f m/s", mask_yaml, int(limited.sum()),
                 float(zones.limits[limited].min()), float(zones.limits[limited].max()))
    return zones


#: Colours (BGR) the pictures give the zones: keepout red, speed zones amber, darker where slower.
KEEPOUT_COLOUR = (60, 60, 220)
SPEED_COLOUR = (0, 170, 255)


def zone_overlay(keepout: np.ndarray | None, speed_limits: np.ndarray | None, max_speed: float) -> np.ndarray | None:
    """A BGRA layer over the map's cells (row 0 at the bottom) showing keepout and speed zones, for
    :class:`~navigation.render.RunPicture`; None when there is nothing to show."""
    shape = keepout.shape if keepout is not None else speed_limits.shape if speed_limits is not None else None
    if shape is None:
        return None
    layer = np.zeros((*shape, 4), np.uint8)
    if speed_limits is not None:
        limited = np.isfinite(speed_limits)
        slowness = 1.0 - np.clip(speed_limits[limited] / max(max_speed, 1e-9), 0.0, 1.0)
        layer[limited, :3] = SPEED_COLOUR
        layer[limited, 3] = np.round(70 + 110 * slowness).astype(np.uint8)
    if keepout is not None:
        layer[keepout, :3] = KEEPOUT_COLOUR
        layer[keepout, 3] = 150
    return layer if layer[..., 3].any() else None


def blend_overlay(image: np.ndarray, layer: np.ndarray) -> np.ndarray:
    """``image`` (BGR, image order: top row first) with a BGRA ``layer`` of the same size blended over it; dark
    pixels (walls) stay as they are, so a zone drawn up to a wall does not hide it."""
    alpha = layer[..., 3:4].astype(np.float32) / 255.0
    alpha[image.mean(axis=-1) < 128] = 0.0
    mixed = image.astype(np.float32) * (1.0 - alpha) + layer[..., :3].astype(np.float32) * alpha
    return np.round(mixed).astype(np.uint8)
