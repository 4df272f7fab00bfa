"""objrec-detect soaked on the demo: memory sampled while it runs tens of thousands of frames.

Each system runs as the real command (``objrec-detect SYSTEM --source demo --max-frames N``) in a child process;
its JSON lines (one per frame) are counted here as they arrive, and its resident memory is read from
``/proc/<pid>/status`` every ``N / samples`` frames. The warm-up is the first 10 % of the frames (imports, first
allocations, caches filled). Memory moves from frame to frame with what each frame holds and what the allocator
hands back (the 3D system swings between about 190 and 240 MB), so each tenth of the run after the warm-up is
summed up by its high-water mark: the baseline is that of the first tenth, the end that of the last, the growth
their difference, and the slope a line fitted through the tenths' marks (MB per 10,000 frames), so that a slow
leak shows even where it stays under the goal; the peak over the baseline is printed beside them. Goal: growth
under 5 MB after warm-up.

    python benchmarks/bench_soak.py [--quick] [--samples 100] [--only hsv,feature,shape]
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = ROOT / "objrec_apps" / "systems"
#: The soak lengths promised per system, and a tenth of them for --quick.
FRAMES = {"hsv": 30_000, "feature": 3_000, "shape": 1_500}
PARAMS = {"hsv": SYSTEMS / "hsv_demo.yaml", "feature": SYSTEMS / "feature_demo.yaml",
          "shape": SYSTEMS / "shape_demo.yaml"}
WARM_UP = 0.10
WINDOW = 0.10  # the stretch of frames summed up by its high-water mark
GOAL_MB = 5.0


@dataclass
class Soak:
    """One system's run: memory samples (frame, MB) and timing."""

    name: str
    frames: int
    samples: list[tuple[int, float]]
    seconds: float  # from the first frame to the last, start-up left out
    startup: float  # from launch to the first frame
    exit_code: int

    def after_warm_up(self) -> list[tuple[int, float]]:
        first = int(self.frames * WARM_UP)
        return [(f, mb) for f, mb in self.samples if f >= first]

    def marks(self) -> list[tuple[float, float]]:
        """(middle frame, highest sample) of each tenth of the run after the warm-up."""
        out = []
        low = WARM_UP
        while low < 1.0 - 1e-9:
            high = min(1.0, low + WINDOW)
            inside = [mb for f, mb in self.samples if low * self.frames < f <= high * self.frames]
            if inside:
                out.append(((low + high) / 2 * self.frames, max(inside)))
            low = high
        return out

    @property
    def baseline(self) -> float:
        return self.marks()[0][1]

    @property
    def end(self) -> float:
        return self.marks()[-1][1]

    @property
    def growth(self) -> float:
        return self.end - self.baseline

    @property
    def growth_peak(self) -> float:
        return max(mb for _, mb in self.after_warm_up()) - self.baseline

    @property
    def slope(self) -> float:
        """MB per 10,000 frames, least squares through the tenths' high-water marks."""
        points = np.array(self.marks(), dtype=float)
        if len(points) < 2:
            return 0.0
        return float(np.polyfit(points[:, 0], points[:, 1], 1)[0] * 10_000)

    @property
    def rate(self) -> float:
        return (self.frames - 1) / self.seconds if self.seconds > 0 else 0.0


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status", encoding="ascii") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError(f"no VmRSS for {pid}")


def soak(name: str, frames: int, samples: int) -> Soak:
    every = max(1, frames // samples)
    command = [str(Path(sys.executable).parent / "objrec-detect"), str(PARAMS[name]), "--source", "demo",
               "--max-frames", str(frames), "--no-progress"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("OBJREC_MAX_")}
    launched = time.monotonic()
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=ROOT)
    assert child.stdout is not None
    taken: list[tuple[int, float]] = []
    count, first = 0, 0.0
    for _line in child.stdout:
        count += 1
        if count == 1:
            first = time.monotonic()
        if count % every == 0 or count == frames:
            taken.append((count, rss_mb(child.pid)))  # the child is alive: its last line is not its exit
    last = time.monotonic()
    _, errors = child.communicate()
    if child.returncode != 0 or count != frames:
        raise SystemExit(f"{name}: exit code {child.returncode}, {count} of {frames} frames: "
                         f"{errors.decode(errors='replace')[-500:]}")
    return Soak(name, frames, taken, last - first, first - launched, child.returncode)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a tenth of the frames")
    parser.add_argument("--samples", type=int, default=100, help="memory samples per run")
    parser.add_argument("--only", default=",".join(FRAMES), help="systems to run, of hsv,feature,shape")
    args = parser.parse_args()

    load_before = os.getloadavg()
    results = []
    for name in args.only.split(","):
        frames = FRAMES[name] // 10 if args.quick else FRAMES[name]
        result = soak(name, frames, args.samples)
        print(f"  {name}: {frames} frames, {result.rate:.1f} frames/s, memory {result.baseline:.1f} MB after "
              f"warm-up, {result.end:.1f} MB at the end", flush=True)
        results.append(result)
    load_after = os.getloadavg()

    print(f"\nobjrec-detect on the demo, memory sampled {args.samples} times per run; warm-up {WARM_UP:.0%} of the "
          f"frames, then the high-water mark of every {WINDOW:.0%}: baseline the first, end the last")
    print(f"machine: {cpu_model()}, {len(os.sched_getaffinity(0))} cores available, Python "
          f"{platform.python_version()}; load average {load_before[0]:.2f} before, {load_after[0]:.2f} after")
    print(f"{'system':>8} {'frames':>7} {'frames/s':>9} {'start (s)':>9} {'baseline MB':>12} {'end MB':>7} "
          f"{'growth MB':>10} {'peak growth':>12} {'MB/10k frames':>14} {'goal':>5}")
    for r in results:
        ok = "ok" if r.growth < GOAL_MB else "OVER"
        print(f"{r.name:>8} {r.frames:>7} {r.rate:>9.1f} {r.startup:>9.2f} {r.baseline:>12.1f} "
              f"{r.end:>7.1f} {r.growth:>10.2f} {r.growth_peak:>12.2f} {r.slope:>14.2f} {ok:>5}")
    print(f"goal: growth under {GOAL_MB:.0f} MB after warm-up")


if __name__ == "__main__":
    main()
