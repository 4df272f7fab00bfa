"""The figures of docs/feature-detection.md's "Which feature type when": every feature type on the demo, the hard
demo and the box pair, each with every parameter at its default (or with simulated views).

- demo: every third of the first 900 frames of ``DemoScene(seed=0)``, the poster selected in frame 0: the share
  of frames with the poster reported within 3 px (largest corner error) and the median corner error.
- hard demo: the same scene with the poster tilting +-46 degrees about both axes, turning +-69 degrees and
  shrinking to 0.6 (``DemoTarget(max_tilt=0.8, max_turn=1.2, min_scale=0.6)``), every fifth of 900 frames: the
  share of frames where it is reported, and where it is reported within 3 px.
- box in scene: box.png selected whole, found in box_in_scene.png (../shared/data/images): its inliers.
- CPU ms per demo frame (``time.process_time`` around ``detect``, OpenCV on one thread; the build of the target
  is not counted): on a shared machine compare types within one run, not with another run's figures.

    python scripts/measure_feature_types.py [--types ORB AKAZE BRISK SIFT KAZE] [--views none sideways all]
        [--demo-step 3] [--hard-step 5] [--frames 900] [--set max_features=2000 orb_fast_threshold=30]

``--views``: ``none`` (the defaults), ``sideways`` and ``all`` (``view_tilts`` 2 with those longitudes), each
measured on the hard demo (and on the plain demo and the box pair for ``none`` only). A type the installed
OpenCV lacks is reported and skipped.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import yaml

from objrec2d import DemoScene, DemoTarget, FeatureDetector
from objrec2d.features import FEATURE_TYPES, corner_error, unavailable_reason
from objrec_core import Rect

ROOT = Path(__file__).resolve().parent.parent
IMAGES = ROOT.parent / "shared" / "data" / "images"
#: The hard demo's poster: how the docs describe it.
HARD_TARGET = {"max_tilt": 0.8, "max_turn": 1.2, "min_scale": 0.6}
VIEWS = {"none": {}, "sideways": {"view_tilts": 2, "view_longitudes": "sideways"},
         "all": {"view_tilts": 2, "view_longitudes": "all"}}
WITHIN = 3.0


def corner_errors(feature_type: str, scene: DemoScene, indices: range, **settings: object
                  ) -> tuple[list[float], float]:
    """Largest corner error per frame (inf where the poster was not reported) and CPU seconds per frame."""
    assert scene.target is not None
    frame, _ = scene.render(0)
    detector = FeatureDetector(feature_type=feature_type, **settings)
    detector.process_area_selection(Rect(*scene.target.reference_rect), frame)
    errors: list[float] = []
    spent = 0.0
    for index in indices:
        image, truth = scene.render(index)
        start = time.process_time()
        found = detector.detect(image)
        spent += time.process_time() - start
        errors.append(corner_error(found.details[0].quadrilateral, truth["target"]["corners"]) if len(found)
                      else float("inf"))
    return errors, spent / len(indices)


def box_inliers(feature_type: str, **settings: object) -> str:
    """Inliers of box.png found in box_in_scene.png, or why not measured."""
    box, scene = (cv2.imread(str(IMAGES / name)) for name in ("box.png", "box_in_scene.png"))
    if box is None or scene is None:
        return "-"
    detector = FeatureDetector(feature_type=feature_type, object_name="box", **settings)
    detector.set_target(box)
    found = detector.detect(scene)
    return str(found.details[0].inlier_count) if len(found) else "missed"


def share(errors: list[float], limit: float = WITHIN) -> float:
    return 100.0 * float(np.mean(np.asarray(errors) <= limit))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--types", nargs="+", default=list(FEATURE_TYPES), choices=FEATURE_TYPES)
    parser.add_argument("--views", nargs="+", default=["none"], choices=list(VIEWS))
    parser.add_argument("--demo-step", type=int, default=3, help="every n-th demo frame (0: leave the demo out)")
    parser.add_argument("--hard-step", type=int, default=5, help="every n-th hard-demo frame")
    parser.add_argument("--frames", type=int, default=900, help="frames of each scene the steps run over")
    parser.add_argument("--set", nargs="+", default=[], metavar="NAME=VALUE",
                        help="detector parameters other than the defaults, e.g. max_features=2000 (YAML values)")
    args = parser.parse_args(argv)
    chosen = {name: yaml.safe_load(value) for name, _, value in (item.partition("=") for item in args.set)}
    cv2.setNumThreads(1)  # one core, as benchmarks/bench_feature.py times it
    print(f"OpenCV {cv2.__version__}; demo every {args.demo_step} of {args.frames} frames, hard demo every "
          f"{args.hard_step}; seed 0")
    print("| type | views | CPU ms/frame (demo) | demo: within 3 px (median) | hard demo: found / within 3 px "
          "| box in scene: inliers |")
    print("|---|---|---|---|---|---|")
    for feature_type in args.types:
        reason = unavailable_reason(feature_type)
        if reason is not None:
            print(f"| {feature_type} | - | {reason} | | | |")
            continue
        for views in args.views:
            settings = {**chosen, **VIEWS[views]}
            demo, cost = "-", "-"
            if args.demo_step and views == "none":
                errors, seconds = corner_errors(feature_type, DemoScene(seed=0), range(0, args.frames,
                                                                                       args.demo_step), **chosen)
                finite = [e for e in errors if np.isfinite(e)]
                median = statistics.median(finite) if finite else float("nan")
                demo, cost = f"{share(errors):.1f} % ({median:.2f} px)", f"{1000 * seconds:.1f}"
            hard_scene = DemoScene(seed=0, target=DemoTarget(**HARD_TARGET))
            errors, _ = corner_errors(feature_type, hard_scene, range(0, args.frames, args.hard_step), **settings)
            found = 100.0 * float(np.mean(np.isfinite(errors)))
            hard = f"{found:.0f} % / {share(errors):.0f} %"
            box = box_inliers(feature_type, **chosen) if views == "none" else "-"
            print(f"| {feature_type} | {views} | {cost} | {demo} | {hard} | {box} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
