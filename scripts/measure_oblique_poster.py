"""The inspection lab's poster seen steeply: the corner error of every feature type's outline, with and without
simulated views (docs/feature-detection.md, "Targets seen steeply").

The 0.8 m poster (examples/inspection_lab/poster.png) ``--distance`` m in front of the lab's 640x480 camera (f 525
px), turned about its vertical axis by each angle, on a grey wall (``turned_homography``, as
tests/objrec2d_features/test_feature_oblique_views.py renders it). Each cell is the largest corner error in px,
or ``missed``; every parameter at its default except ``view_tilts`` and ``view_longitudes``.

    python scripts/measure_oblique_poster.py [--types ORB AKAZE BRISK KAZE SIFT] [--angles 60 62 65 70]
        [--views none sideways all] [--distance 1.4] [--keypoints-only]

``--keypoints-only`` switches the photometric refinement off (the keypoint fit alone).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from objrec2d import FeatureDetector
from objrec2d.features import FEATURE_TYPES, corner_error, rect_corners, unavailable_reason
from objrec2d.features.geometry import project
from objrec2d.features.view_synthesis import turned_homography
from objrec_core import Rect

ROOT = Path(__file__).resolve().parent.parent
POSTER = ROOT / "examples" / "inspection_lab" / "poster.png"
VIEWS = {"none": {}, "sideways": {"view_tilts": 2, "view_longitudes": "sideways"},
         "all": {"view_tilts": 2, "view_longitudes": "all"}}


def seen(poster: np.ndarray, angle: float, distance: float) -> tuple[np.ndarray, np.ndarray]:
    """The frame and the poster's true corners in it."""
    height, width = poster.shape[:2]
    homography = turned_homography((width, height), angle, distance)
    wall = np.full((480, 640, 3), 150, np.uint8)
    frame = cv2.warpPerspective(poster, homography, (640, 480), dst=wall, borderMode=cv2.BORDER_TRANSPARENT)
    return frame, project(homography, rect_corners(Rect(0, 0, width, height)))[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--types", nargs="+", default=list(FEATURE_TYPES), choices=FEATURE_TYPES)
    parser.add_argument("--angles", nargs="+", type=float, default=[60.0, 62.0, 65.0, 70.0])
    parser.add_argument("--views", nargs="+", default=["none", "sideways"], choices=list(VIEWS))
    parser.add_argument("--distance", type=float, default=1.4, help="metres from the camera")
    parser.add_argument("--keypoints-only", action="store_true", help="no photometric refinement")
    args = parser.parse_args(argv)
    poster = cv2.imread(str(POSTER))
    if poster is None:
        print(f"cannot read {POSTER}", file=sys.stderr)
        return 1
    frames = {angle: seen(poster, angle, args.distance) for angle in args.angles}
    print(f"OpenCV {cv2.__version__}; poster {args.distance:g} m away; photometric refinement "
          f"{'off' if args.keypoints_only else 'on'}")
    print("| type | views | " + " | ".join(f"{angle:g} deg" for angle in args.angles) + " |")
    print("|---|---|" + "---|" * len(args.angles))
    for feature_type in args.types:
        if unavailable_reason(feature_type) is not None:
            continue
        for views in args.views:
            detector = FeatureDetector(feature_type=feature_type, photometric_refinement=not args.keypoints_only,
                                       **VIEWS[views])
            detector.set_target(poster)
            cells = []
            for frame, truth in frames.values():
                found = detector.detect(frame)
                cells.append(f"{corner_error(found.details[0].quadrilateral, truth):.2f} px" if len(found)
                             else "missed")
            print(f"| {feature_type} | {views} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
