"""The colour system under colour casts, with and without a white-balance filter in front.

The lighting set: the demo's scenes (``demo:seed=S`` frame 0 for 10 seeds, truth from the renderer) and
smarties.png (hand labels, tests/data/labels/smarties.coco.json), each taken under lights of several colour
temperatures by a camera balanced for daylight (6,500 K), and by one left on its tungsten preset (3,200 K)
under daylight and cooler lights, the strong blue casts (``objrec2d.lighting.colour_cast``). Each system is
scored as objrec-eval scores it (box IoU >= 0.5, names or groups agree): true and false objects per light.

    python scripts/measure_white_balance.py [--system params/hsv_demo.yaml] [--seeds 10]
        [--kelvin 2500 3500 5000 6500 9000 12000 20000] [--tungsten-kelvin 5000 6500 9000 12000]
        [--picture out/white-balance.png]

Without ../shared/data the smarties rows are left out (said on stderr).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

from objrec2d import DemoSource
from objrec2d.lighting import DAYLIGHT_K, TUNGSTEN_K, colour_cast
from objrec2d.white_balance_filter import WhiteBalanceFilter
from objrec_core import Frame, RecognitionSystem, build_system, get_kind
from objrec_core.evaluation import score

ROOT = Path(__file__).resolve().parent.parent
SMARTIES = ROOT.parent / "shared" / "data" / "images" / "smarties.png"
LABELS = ROOT / "tests" / "data" / "labels" / "smarties.coco.json"


def balanced(system_file: Path, method: str | None) -> RecognitionSystem:
    """The system from its file, with a WhiteBalanceFilter of ``method`` first (None: as shipped)."""
    system = build_system(system_file)
    if method is not None:
        system.add_module(WhiteBalanceFilter(id="white_balance", method=method), 0)
    return system


def scenes(seeds: int) -> list[tuple[str, Frame, object]]:
    """(set name, frame, truth) of the lighting set's daylight originals."""
    kind = get_kind("2d")
    found: list[tuple[str, Frame, object]] = []
    for seed in range(seeds):
        with DemoSource(seed=seed, frames=1) as source:
            frame = next(iter(source))
        found.append(("demo", frame, kind.frame_truth(frame)))
    if SMARTIES.is_file():
        truth = kind.read_truth(LABELS)
        image = cv2.imread(str(SMARTIES))
        found.append(("smarties", Frame(image, index=0), truth.frames[0]))
    else:
        print(f"{SMARTIES} not found: the smarties rows are left out", file=sys.stderr)
    return found


def counts(system: RecognitionSystem, labelled: list[tuple[Frame, object]]) -> tuple[int, int, int]:
    """(true objects found, false objects, truth) of ``system`` on ``labelled``."""
    evaluation = score(system, get_kind("2d"), labelled)
    (row,) = [r for r in evaluation.summary_rows() if r["name"] == "all"]
    return int(row["tp"]), int(row["fp"]), int(row["truth"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--system", type=Path, default=ROOT / "params" / "hsv_demo.yaml")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--kelvin", type=float, nargs="+", default=[2500, 3500, 5000, 6500, 9000, 12000, 20000])
    parser.add_argument("--tungsten-kelvin", type=float, nargs="+", default=[5000, 6500, 9000, 12000])
    parser.add_argument("--picture", type=Path, help="a grid of the cast demo scene 0 before and after balancing")
    args = parser.parse_args()
    originals = scenes(args.seeds)
    methods = [None, "gray_world", "white_patch"]
    print("| set | camera balanced for (K) | light (K) | truth | " + " | ".join(
        f"{m or 'no balance'}: found / false" for m in methods) + " |")
    print("|---|---|---|---|" + "---|" * len(methods))
    lights = [(DAYLIGHT_K, k) for k in args.kelvin] + [(TUNGSTEN_K, k) for k in args.tungsten_kelvin]
    for name in dict.fromkeys(n for n, _, _ in originals):
        for camera, kelvin in lights:
            labelled = [(Frame(colour_cast(f.data, kelvin, camera), index=f.index, truth=f.truth), t)
                        for n, f, t in originals if n == name]
            cells = []
            truth_total = 0
            for method in methods:
                tp, fp, truth_total = counts(balanced(args.system, method), labelled)
                cells.append(f"{tp} / {fp}")
            print(f"| {name} | {camera:g} | {kelvin:g} | {truth_total} | " + " | ".join(cells) + " |")
    if args.picture is not None:
        picture(originals[0][1].data, lights, args.picture)


def picture(image: np.ndarray, lights: list[tuple[float, float]], path: Path) -> None:
    """Row 1: the scene under each light (camera preset / light); row 2: the same after the gray-world filter."""
    balance = WhiteBalanceFilter(method="gray_world")
    small = [cv2.resize(colour_cast(image, k, c), (160, 120), interpolation=cv2.INTER_AREA) for c, k in lights]
    fixed = [balance.filter(s) for s in small]
    for tile, (camera, kelvin) in zip(small, lights, strict=True):
        cv2.putText(tile, f"{camera / 1000:g}k/{kelvin / 1000:g}k", (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (255, 255, 255), 1, cv2.LINE_AA)
    grid = np.vstack([np.hstack(small), np.hstack(fixed)])
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), grid)


if __name__ == "__main__":
    main()
