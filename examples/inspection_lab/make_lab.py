"""Make the generated files of the inspection example: the lab's map, the poster image and its parameter file.

    .venv/bin/python examples/inspection_lab/make_lab.py

Writes ``lab.yaml`` + ``lab.pgm`` (a 9 m x 7 m room with walls, a cabinet in the middle and a bench along
the north wall), ``poster.png`` (a textured poster, deterministic), and ``params/poster_2d.yaml`` (a
FeatureDetector that looks for that poster, its picture stored in the file). The world, the poses, the
mission and the other parameter files are written by hand beside them.
"""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import numpy as np

from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, UNKNOWN, OccupancyMap, save_map
from objrec2d.feature_detector import FeatureDetector
from objrec_core import ParameterStorage, RecognitionSystem

HERE = Path(__file__).resolve().parent
RESOLUTION = 0.05
SIZE = (9.0, 7.0)
WALL = 0.15
ROOM = (0.5, 0.5, 8.5, 6.5)
FURNITURE = [
    (3.8, 2.9, 5.2, 3.7),   # the cabinet in the middle of the room
    (5.6, 6.05, 8.5, 6.5),  # the bench along the north wall
]
POSTER_SIZE = (480, 360)  # pixels, for a 0.8 m x 0.6 m poster

log = logging.getLogger("make_lab")


def build_map() -> OccupancyMap:
    width, height = round(SIZE[0] / RESOLUTION), round(SIZE[1] / RESOLUTION)
    grid = np.full((height, width), UNKNOWN, np.int8)

    def cells(x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice]:
        return (slice(round(y0 / RESOLUTION), round(y1 / RESOLUTION)),
                slice(round(x0 / RESOLUTION), round(x1 / RESOLUTION)))

    x0, y0, x1, y1 = ROOM
    grid[cells(x0 - WALL, y0 - WALL, x1 + WALL, y1 + WALL)] = OCCUPIED
    grid[cells(*ROOM)] = FREE
    for box in FURNITURE:
        grid[cells(*box)] = OCCUPIED
    return OccupancyMap(grid, RESOLUTION, Pose2D(0.0, 0.0, 0.0))


def build_poster() -> np.ndarray:
    """A safety-notice poster with enough corners and texture for ORB at two metres."""
    w, h = POSTER_SIZE
    rng = np.random.default_rng(11)
    img = np.full((h, w, 3), (235, 245, 250), np.uint8)
    cv2.rectangle(img, (0, 0), (w - 1, 70), (20, 140, 240), -1)
    cv2.putText(img, "LAB 3 SAFETY", (22, 52), cv2.FONT_HERSHEY_DUPLEX, 1.55, (255, 255, 255), 3, cv2.LINE_AA)
    for k in range(6):  # a row of warning triangles
        cx = 45 + k * 78
        pts = np.array([[cx, 95], [cx - 30, 150], [cx + 30, 150]], np.int32)
        cv2.fillPoly(img, [pts], (0, 200, 250))
        cv2.polylines(img, [pts], True, (20, 20, 20), 3, cv2.LINE_AA)
        cv2.putText(img, "!", (cx - 6, 143), cv2.FONT_HERSHEY_DUPLEX, 1.0, (20, 20, 20), 2, cv2.LINE_AA)
    for k in range(5):  # lines of text
        y = 185 + 26 * k
        words = ["GOGGLES", "GLOVES", "NO FOOD", "EXIT", "FIRST AID", "CALL 112", "LASER", "CLEAN UP"]
        text = " ".join(words[(k * 3 + j) % len(words)] for j in range(3))
        cv2.putText(img, text, (20, y), cv2.FONT_HERSHEY_SIMPLEX, 0.72, (40, 40, 40), 2, cv2.LINE_AA)
    for _ in range(14):  # coloured dots and squares in the lower right
        x, y = int(rng.integers(300, w - 20)), int(rng.integers(190, h - 20))
        colour = tuple(int(c) for c in rng.integers(0, 200, 3))
        if rng.random() < 0.5:
            cv2.circle(img, (x, y), int(rng.integers(6, 16)), colour, -1, cv2.LINE_AA)
        else:
            s = int(rng.integers(8, 18))
            cv2.rectangle(img, (x - s, y - s), (x + s, y + s), colour, -1)
    cv2.rectangle(img, (0, h - 28), (w - 1, h - 1), (40, 40, 40), -1)
    for k in range(0, w, 24):  # a hazard stripe
        cv2.fillPoly(img, [np.array([[k, h - 1], [k + 12, h - 28], [k + 24, h - 28], [k + 12, h - 1]])],
                     (0, 210, 255))
    cv2.rectangle(img, (0, 0), (w - 1, h - 1), (30, 30, 30), 4)
    return img


def build_poster_parameters(poster: np.ndarray, path: Path) -> None:
    """A FeatureDetector taught the poster from its image, saved as a parameter file."""
    detector = FeatureDetector("poster", object_name="poster", feature_type="ORB", max_features=1500,
                               min_matches=12, min_inliers=12, reprojection_threshold=4.0,
                               view_tilts=2, view_longitudes="sideways", debug_view="side_by_side")
    detector.set_target(poster)
    system = RecognitionSystem([detector], object_name="poster",
                               description="The lab's safety poster, found by ORB keypoints and a homography. "
                                           "Made by examples/inspection_lab/make_lab.py from poster.png.")
    ParameterStorage(system).save_parameters(path)


def main() -> None:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    out = save_map(build_map(), HERE / "lab.yaml", image_format="pgm")
    log.info("wrote %s and %s", out, out.with_suffix(".pgm"))
    poster = build_poster()
    cv2.imwrite(str(HERE / "poster.png"), poster)
    log.info("wrote %s", HERE / "poster.png")
    (HERE / "params").mkdir(exist_ok=True)
    build_poster_parameters(poster, HERE / "params" / "poster_2d.yaml")
    log.info("wrote %s", HERE / "params" / "poster_2d.yaml")


if __name__ == "__main__":
    main()
