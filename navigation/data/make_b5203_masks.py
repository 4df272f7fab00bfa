"""Draw the costmap-filter masks of the keepout and speed-zone exercises for room B5.2.03.

Nav2's format: each mask is a map_server YAML + image. The keepout mask (trinary PGM) closes the north side of
the room between goals 3 and 4, so the patrol must go round south of it; the speed mask (``mode: scale`` PNG,
as Nav2's tutorial draws it) marks the south strip by goals 9 and 10 with value 60: 100 - 60 = 40 % of the
maximum speed. Both masks are 0.1 m a cell, twice the map's cell, to show that a mask need not share the map's
grid. ``b5203_nav.yaml`` names both. Run it to regenerate the files: ``python navigation/data/make_b5203_masks.py``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from navigation.costmap_filters import box_mask
from navigation.maps import OCCUPIED, save_map

RESOLUTION = 0.1
SIZE = (28.8, 25.6)
KEEPOUT = (12.6, 12.9, 13.4, 15.0)  # x0, y0, x1, y1 in metres
SPEED_ZONE = (12.0, 9.9, 15.0, 11.8)
SPEED_VALUE = 60  # percent filter, base 100, multiplier -1: 40 % of the maximum speed

PARAMS = """\
# Navigation parameters for the B5.2.03 exercises (objrec-patrol --nav-params); see docs/navigation.md.
planner:
  inflation_margin: 0.10      # m of lethal inflation beyond the robot's 0.18 m radius
  cost_scaling_factor: 6.67   # 1/m: how fast the cost decays beyond the lethal zone (Nav2's name)
controller:
  max_speed: 0.5              # m/s, at most the base's 0.5
  acceleration: 1.0           # m/s^2 the controller brakes with, at most the base's 1.0
  lookahead: 0.35             # m, pure pursuit's carrot
filters:
  keepout_mask: b5203_keepout.yaml
  speed_mask: b5203_speed.yaml
  speed_limit: {type: percent, base: 100, multiplier: -1}
"""


def main() -> None:
    here = Path(__file__).parent
    save_map(box_mask(SIZE, RESOLUTION, KEEPOUT, OCCUPIED), here / "b5203_keepout.yaml", image_format="pgm")
    save_map(box_mask(SIZE, RESOLUTION, SPEED_ZONE, SPEED_VALUE), here / "b5203_speed.yaml", image_format="png",
             mode="scale")
    (here / "b5203_nav.yaml").write_text(PARAMS, encoding="utf-8")
    logging.getLogger(__name__).info("wrote the B5.2.03 masks and parameters in %s", here)


if __name__ == "__main__":
    main()
