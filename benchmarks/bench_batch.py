"""objrec-batch on 1 and on 2 worker processes: the same recordings, the same system, the speed-up.

Makes N short videos of the 2D demo scene (MJPG, as a camera recording would be), then runs the batch in this
process (``make_plan`` and ``run_batch``, what ``objrec-batch`` runs) with 1 and with 2 workers, alternating
which goes first over the repeats and keeping each side's best: a load that comes and goes on a shared machine
hits both alike. Two figures per side: the whole batch (the cluster's start and close included, what a user
waits for) and the work (from the first source handed out to the last row back). Both runs must give the same
rows, or the comparison means nothing. Target: at least 1.6x on 2 cores.

    python benchmarks/bench_batch.py [--recordings 8] [--frames 60] [--repeats 3] [--params params/hsv_demo.yaml]
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
from pathlib import Path

import cv2
from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

from objrec_apps.batch import BatchOutcome, make_plan, run_batch
from objrec_core import open_source

ROOT = Path(__file__).resolve().parents[1]


def make_recordings(folder: Path, count: int, frames: int) -> list[str]:
    paths = []
    for seed in range(1, count + 1):
        path = folder / f"recording{seed}.avi"
        with open_source(f"demo:seed={seed},frames={frames}", "2d") as source:
            images = [frame.data for frame in source]
        height, width = images[0].shape[:2]
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (width, height))
        for image in images:
            writer.write(image)
        writer.release()
        paths.append(str(path))
    return paths




def rows(outcome: BatchOutcome) -> list[tuple[str, int, int, int, str]]:
    return [(r.output, r.frames, r.frames_with_objects, r.objects, r.status) for r in outcome.results]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recordings", type=int, default=8)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--params", default=str(ROOT / "params" / "hsv_demo.yaml"))
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="bench_batch.") as tmp:
        sources = make_recordings(Path(tmp), args.recordings, args.frames)
        load_before = os.getloadavg()
        best: dict[int, tuple[float, float]] = {}
        reference: dict[int, list] = {}
        for repeat in range(args.repeats):
            for workers in (1, 2) if repeat % 2 == 0 else (2, 1):
                plan = make_plan(args.params, sources, str(Path(tmp) / f"out{workers}"))
                outcome = run_batch(plan, workers=workers)
                assert not outcome.failed, [r.status for r in outcome.failed]
                assert sum(r.frames for r in outcome.results) == args.recordings * args.frames
                reference.setdefault(workers, rows(outcome))
                assert rows(outcome) == reference[workers]
                total, work = best.get(workers, (float("inf"), float("inf")))
                best[workers] = (min(total, outcome.seconds), min(work, outcome.work_seconds))
                print(f"  repeat {repeat + 1}, {workers} worker(s): {outcome.seconds:.2f} s in all, "
                      f"{outcome.work_seconds:.2f} s of work")
        assert reference[1] == reference[2], "1 and 2 workers gave different rows"
        load_after = os.getloadavg()

    frames = args.recordings * args.frames
    print(f"\nobjrec-batch, {args.recordings} recordings x {args.frames} frames ({frames} frames), "
          f"{Path(args.params).name}, best of {args.repeats}")
    print(f"machine: {cpu_model()}, {len(os.sched_getaffinity(0))} cores available, Python "
          f"{platform.python_version()}; load average {load_before[0]:.2f} before, {load_after[0]:.2f} after")
    print(f"{'workers':>8} {'in all (s)':>11} {'work (s)':>9} {'frames/s (work)':>16}")
    for workers in (1, 2):
        total, work = best[workers]
        print(f"{workers:>8} {total:>11.2f} {work:>9.2f} {frames / work:>16.1f}")
    print(f"speed-up with 2 workers: {best[1][1] / best[2][1]:.2f}x on the work, "
          f"{best[1][0] / best[2][0]:.2f}x in all (target: at least 1.6x)")


if __name__ == "__main__":  # the local cluster's worker processes import this file again
    main()
