"""The HSV colour pipeline through DetectionDirector against the same OpenCV calls written bare.

Both run on the same pre-rendered 640x480 frames in the same process, frame by frame, alternating which side
goes first, and each frame's time is the best of the repeats: a load that comes and goes on a shared machine
hits both alike, and the ratio is what the framework costs (parameter snapshots, message objects, the header).
Two sets in one run: the demo's frames (four objects each) and busy frames (about 120 saturated blobs on a
noisy background, a dozen cut by the frame edge), where the per-object costs show. The bare side does the
detector's whole job: the length, border and area rules and the convex hull, with each object's truncated
flag. Target: at most 1.05x on both.

    python benchmarks/bench_2d.py [--frames 200] [--repeats 7] [--busy-frames 60]
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
MAX_AREA_FRACTION = 0.9


def bare(image: np.ndarray, kernel: np.ndarray) -> list[tuple[np.ndarray, bool]]:
    """(hull, truncated) per object: BinaryDetector's rules at its defaults, written as a script would."""
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    mask = cv2.inRange(hsv, LOW, HIGH)
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel, iterations=1)
    height, width = mask.shape
    max_area = MAX_AREA_FRACTION * width * height
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    found = []
    for c in contours:
        if not MIN_LEN <= cv2.arcLength(c, True) <= MAX_LEN or cv2.contourArea(c) > max_area:
            continue
        x, y, w, h = cv2.boundingRect(c)
        found.append((cv2.convexHull(c), x == 0 or y == 0 or x + w == width or y + h == height))
    return found


def busy_frames(count: int, seed: int = 0) -> list[Frame]:
    """640x480 frames of about 120 saturated ellipses and boxes (5-30 px) on grey noise, some cut by the edge:
    the per-object work of a cluttered scene, which the demo's four objects hardly show."""
    rng = np.random.default_rng(seed)
    frames = []
    for index in range(count):
        image = rng.normal(110, 25, (480, 640, 3)).clip(0, 255).astype(np.uint8)
        for _ in range(120):
            colour = cv2.cvtColor(np.uint8([[[rng.integers(0, 180), rng.integers(150, 256), 200]]]),
                                  cv2.COLOR_HSV2BGR)[0, 0].tolist()
            centre = (int(rng.integers(-10, 650)), int(rng.integers(-10, 490)))
            axes = (int(rng.integers(5, 30)), int(rng.integers(5, 30)))
            if rng.random() < 0.5:
                cv2.ellipse(image, centre, axes, float(rng.uniform(0, 180)), 0, 360, colour, -1)
            else:
                cv2.rectangle(image, centre, (centre[0] + axes[0], centre[1] + axes[1]), colour, -1)
        frames.append(Frame(image, index=index))
    return frames


def measure(director: DetectionDirector, frames: list[Frame], kernel: np.ndarray, repeats: int
            ) -> tuple[float, float]:
    """Mean per-frame seconds (bare, objrec), each frame the best of ``repeats`` interleaved runs."""
    # Same answers first: a benchmark of two different computations would mean nothing.
    for frame in frames[:20]:
        ours = director.process(frame).objects
        theirs = bare(frame.data, kernel)
        assert len(ours) == len(theirs), (len(ours), len(theirs))
        assert sorted(o.truncated for o in ours) == sorted(t for _, t in theirs)
    bare_best = [math.inf] * len(frames)
    ours_best = [math.inf] * len(frames)
    # This thread's CPU time (OpenCV runs on it alone, setNumThreads(1)): on a machine shared with other work,
    # wall-clock time counts the moments the thread waits for a core, which hit one side or the other.
    clock = time.thread_time
    for repeat in range(repeats):
        for i, frame in enumerate(frames):
            for side in ((0, 1) if (i + repeat) % 2 else (1, 0)):
                start = clock()
                if side == 0:
                    bare(frame.data, kernel)
                    bare_best[i] = min(bare_best[i], clock() - start)
                else:
                    director.process(frame)
                    ours_best[i] = min(ours_best[i], clock() - start)
    return statistics.fmean(bare_best), statistics.fmean(ours_best)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--busy-frames", type=int, default=60)
    args = parser.parse_args()
    cv2.setNumThreads(1)  # both sides on one core, as on a busy robot

    sets = {"demo": [Frame(f.data, f.stamp, f.index) for f in DemoSource(frames=args.frames)],
            "busy": busy_frames(args.busy_frames)}
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
    print(
        f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"OpenCV {cv2.__version__}, 1 OpenCV thread; per frame the best of {args.repeats} interleaved repeats, "
        "thread CPU time"
    )
    for name, frames in sets.items():
        b, o = measure(director, frames, kernel, args.repeats)
        objects = statistics.fmean(len(director.process(f).objects) for f in frames)
        print(f"{name:5} {len(frames):4} x 640x480, {objects:5.1f} objects/frame: bare {b * 1e3:7.3f} ms, "
              f"objrec {o * 1e3:7.3f} ms, framework {(o - b) * 1e3:6.3f} ms/frame, ratio {o / b:.3f}x")
    print("target: ratio <= 1.05x")


if __name__ == "__main__":
    main()
