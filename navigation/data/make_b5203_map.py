"""Draw the shipped map of room B5.2.03 (b5203.pgm + b5203.yaml) so the shipped poses have a room.

The original lab's map is not available, so this is a plausible lab laid out around its poses: the patrol
loop circles a central table, a door in the west wall opens onto a corridor, benches line the north and
south walls, a cabinet stands at the east wall, and the docking station sits about one metre in front of
the station pose (14.4, 12.8), facing it. The frame matches the original Stage world: 28.8 m x 25.6 m,
origin at (0, 0). Run it to regenerate the files: ``python navigation/data/make_b5203_map.py``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, UNKNOWN, OccupancyMap, save_map

RESOLUTION = 0.05
SIZE = (28.8, 25.6)
WALL = 0.15

# Free floor: (x0, y0, x1, y1) in metres.
FLOOR = [
    (9.8, 9.9, 17.6, 15.0),    # the room
    (7.6, 6.0, 9.65, 20.0),    # the corridor west of it
    (9.6, 12.75, 9.85, 13.65),  # the door between them (0.9 m wide)
]
# Furniture, drawn as occupied after the walls.
FURNITURE = [
    (11.6, 14.4, 16.8, 15.0),   # bench along the north wall
    (12.2, 9.9, 17.0, 10.4),    # bench along the south wall
    (12.0, 11.85, 13.4, 12.55),  # the central table the patrol circles
    (17.25, 10.6, 17.6, 12.2),  # cabinet at the east wall
    (9.8, 14.6, 10.3, 15.0),    # bin in the north-west corner
]


def build() -> OccupancyMap:
    width, height = round(SIZE[0] / RESOLUTION), round(SIZE[1] / RESOLUTION)
    grid = np.full((height, width), UNKNOWN, np.int8)

    def cells(x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice]:
        return (slice(round(y0 / RESOLUTION), round(y1 / RESOLUTION)),
                slice(round(x0 / RESOLUTION), round(x1 / RESOLUTION)))

    for x0, y0, x1, y1 in FLOOR[:2]:  # walls: a ring of occupied cells around each free area
        grid[cells(x0 - WALL, y0 - WALL, x1 + WALL, y1 + WALL)] = OCCUPIED
    for box in FLOOR:
        grid[cells(*box)] = FREE
    for box in FURNITURE:
        grid[cells(*box)] = OCCUPIED
    return OccupancyMap(grid, RESOLUTION, Pose2D(0.0, 0.0, 0.0))


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    out = save_map(build(), Path(__file__).with_name("b5203.yaml"), image_format="pgm")
    logging.getLogger(__name__).info("wrote %s and %s", out, out.with_suffix(".pgm"))
