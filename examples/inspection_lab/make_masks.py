"""Draw the costmap-filter masks of the inspection lab (objrec-inspect --nav-params lab_nav.yaml).

Nav2's format, as ``navigation/data/make_b5203_masks.py`` draws B5.2.03's: the keepout mask (trinary PGM) closes a
band west of the table, across the straight way from the station to POSE_0, so the robot must go round it to the
west; the speed mask (``mode: scale`` PNG) marks the floor round POSE_2 with value 60: 100 - 60 = 40 % of the
maximum speed. ``lab_nav.yaml`` names both. Run it to regenerate the files:
``.venv/bin/python examples/inspection_lab/make_masks.py``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from navigation.costmap_filters import box_mask
from navigation.maps import OCCUPIED, save_map

RESOLUTION = 0.1
SIZE = (9.0, 7.0)  # the lab map's extent, metres
KEEPOUT = (1.9, 2.6, 3.7, 3.4)  # x0, y0, x1, y1 in metres
SPEED_ZONE = (5.0, 1.0, 7.0, 2.4)
SPEED_VALUE = 60  # percent filter, base 100, multiplier -1: 40 % of the maximum speed

PARAMS = """\
# Navigation parameters of the inspection lab (objrec-inspect --nav-params); see docs/inspection.md.
filters:
  keepout_mask: lab_keepout.yaml
  speed_mask: lab_speed.yaml
  speed_limit: {type: percent, base: 100, multiplier: -1}
"""


def main() -> None:
    here = Path(__file__).parent
    save_map(box_mask(SIZE, RESOLUTION, KEEPOUT, OCCUPIED), here / "lab_keepout.yaml", image_format="pgm")
    save_map(box_mask(SIZE, RESOLUTION, SPEED_ZONE, SPEED_VALUE), here / "lab_speed.yaml", image_format="png",
             mode="scale")
    (here / "lab_nav.yaml").write_text(PARAMS, encoding="utf-8")
    logging.getLogger(__name__).info("wrote the lab's masks and parameters in %s", here)


if __name__ == "__main__":
    main()
