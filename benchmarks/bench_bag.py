"""Reading frames from a ROS bag against reading the same frames from files, in the same run.

Images: the 2D demo's 640x480 frames as ``sensor_msgs/Image`` (bgr8) in a ROS 1 bag and in a ROS 2 MCAP bag,
against the same frames as PNG files in a folder. Clouds: the 3D demo's organized 640x480 clouds as
``sensor_msgs/PointCloud2`` (PCL's 32-byte layout) against the same clouds as binary PCD files. Each side reads
every frame through ``objrec_core.open_source`` (what ``objrec-detect`` does), best of the repeats. Then
objrec-batch with 1 and 2 workers over the recordings (``bench_batch.py``'s measurement), for the speed-up.

    python benchmarks/bench_bag.py [--images 60] [--clouds 10] [--repeats 3] [--no-batch]
"""

from __future__ import annotations

import argparse
import importlib.util
import platform
import sys
import tempfile
import time
from pathlib import Path

import cv2

from objrec3d import write_pcd
from objrec_core import open_source

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def read_all(spec: str, kind: str) -> tuple[int, float]:
    """Frames read and seconds taken, for every frame of a source."""
    start = time.perf_counter()
    count = sum(1 for _ in open_source(spec, kind))
    return count, time.perf_counter() - start


def best(spec: str, kind: str, repeats: int) -> tuple[int, float]:
    runs = [read_all(spec, kind) for _ in range(repeats)]
    return runs[0][0], min(seconds for _, seconds in runs)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", type=int, default=60)
    parser.add_argument("--clouds", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-batch", action="store_true", help="skip the objrec-batch speed-up")
    args = parser.parse_args(argv)
    recorder = _load("record_demo_bag", ROOT / "scripts" / "record_demo_bag.py")
    print(f"machine: {platform.machine()}, Python {platform.python_version()}, OpenCV {cv2.__version__}")
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        folder = work / "png"
        folder.mkdir()
        for frame in open_source(f"demo:frames={args.images}", "2d"):
            cv2.imwrite(str(folder / f"{frame.index:05d}.png"), frame.data)
        clouds = work / "pcd"
        clouds.mkdir()
        for frame in open_source(f"demo:frames={args.clouds}", "3d"):
            write_pcd(clouds / f"{frame.index:05d}.pcd", frame.data, "binary")
        bags = {"ROS 1 .bag": work / "images.bag", "ROS 2 MCAP": work / "images_mcap"}
        for path in bags.values():
            recorder.record(path, args.images, ["2d"], 0)
        cloud_bag = work / "clouds_mcap"
        recorder.record(cloud_bag, args.clouds, ["3d"], 0)

        print(f"\nimages: {args.images} frames of 640x480, best of {args.repeats}")
        count, files = best(str(folder), "2d", args.repeats)
        print(f"  {'PNG folder':<12} {count / files:8.1f} frames/s  (baseline)")
        for name, path in bags.items():
            count, seconds = best(str(path), "2d", args.repeats)
            print(f"  {name:<12} {count / seconds:8.1f} frames/s  {files / seconds:5.2f}x the files' rate")
        print(f"\nclouds: {args.clouds} organized 640x480 clouds, best of {args.repeats}")
        count, files = best(str(clouds), "3d", args.repeats)
        print(f"  {'binary PCD':<12} {count / files:8.1f} frames/s  (baseline)")
        count, seconds = best(str(cloud_bag), "3d", args.repeats)
        print(f"  {'PointCloud2':<12} {count / seconds:8.1f} frames/s  {files / seconds:5.2f}x the files' rate")
    if not args.no_batch:
        print("\nobjrec-batch, 1 and 2 workers (benchmarks/bench_batch.py):", flush=True)
        return _load("bench_batch", ROOT / "benchmarks" / "bench_batch.py").main([])
    return 0


if __name__ == "__main__":
    sys.exit(main())
