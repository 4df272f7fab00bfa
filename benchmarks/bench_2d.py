"""The HSV colour pipeline through DetectionDirector against the same five OpenCV calls written bare.

Both run on the same pre-rendered 640x480 demo frames in the same process, frame by frame, alternating which
side goes first, and each frame's time is the best of the repeats: a load that comes and goes on a shared
machine hits both alike, and the ratio is what the framework costs (parameter snapshots, message objects,
the header). Target: at most 1.10x.

    python benchmarks/bench_2d.py [--frames 200] [--repeats 7]
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import time

import cv2
import numpy as np

from objrec2d import BinaryDetector, DemoSource, HSVFilter, MorphologyFilter
from objrec_core import DetectionDirector, Frame, RecognitionSystem

LOW, HIGH = (0, 120, 60), (179, 255, 255)
MIN_LEN, MAX_LEN = 40.0, 5000.0


def bare(image: np.ndarray, kernel: np.ndarray) -> list[np.ndarray]:
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    mask = cv2.inRange(hsv, LOW, HIGH)
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel, iterations=1)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    return [cv2.convexHull(c) for c in contours if MIN_LEN <= cv2.arcLength(c, True) <= MAX_LEN]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    cv2.setNumThreads(1)  # both sides on one core, as on a busy robot

    frames = [Frame(f.data, f.stamp, f.index) for f in DemoSource(frames=args.frames)]
    system = RecognitionSystem(
        [
            HSVFilter(h_min=LOW[0], h_max=HIGH[0], s_min=LOW[1], v_min=LOW[2]),
            MorphologyFilter(operation="open", iterations=1, kernel_size=3),
            BinaryDetector(min_contour_length=MIN_LEN, max_contour_length=MAX_LEN),
        ],
        object_name="object",
    )
    director = DetectionDirector(system)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))

    # Same answers first: a benchmark of two different computations would mean nothing.
    for frame in frames[:20]:
        ours = director.process(frame).objects
        theirs = bare(frame.data, kernel)
        assert len(ours) == len(theirs), (len(ours), len(theirs))

    bare_best = [math.inf] * len(frames)
    ours_best = [math.inf] * len(frames)
    clock = time.perf_counter
    for repeat in range(args.repeats):
        for i, frame in enumerate(frames):
            for side in ((0, 1) if (i + repeat) % 2 else (1, 0)):
                start = clock()
                if side == 0:
                    bare(frame.data, kernel)
                    bare_best[i] = min(bare_best[i], clock() - start)
                else:
                    director.process(frame)
                    ours_best[i] = min(ours_best[i], clock() - start)

    b, o = statistics.fmean(bare_best), statistics.fmean(ours_best)
    print(
        f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"OpenCV {cv2.__version__}, 1 OpenCV thread"
    )
    print(f"frames: {len(frames)} x 640x480; per frame the best of {args.repeats} interleaved repeats")
    print(f"bare OpenCV   : {b * 1e3:7.3f} ms/frame  ({1 / b:7.1f} frames/s)")
    print(f"objrec        : {o * 1e3:7.3f} ms/frame  ({1 / o:7.1f} frames/s)")
    print(f"ratio objrec/bare: {o / b:.3f}x (target <= 1.10x)")


if __name__ == "__main__":
    main()
