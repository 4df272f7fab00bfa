"""Camera benchmark: frames per second of the simulated RGB-D camera at 640x480 in a room with 10 objects.

    .venv/bin/python benchmarks/bench_camera.py [--frames N] [--width W --height H]

Target: >= 30 frames/s (a real Astra's rate) for a whole frame: walls, floor, the objects and obstacles,
depth noise, grazing-angle dropout and the organized point cloud. Two runs: the robot driving a loop
around the room (objects come and go out of view), and standing where all ten objects are in view at once.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import time

import cv2
import numpy as np
from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

from navigation.camera import CameraParams, RGBDCamera
from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, OccupancyMap
from navigation.world import MovingObstacle, World, WorldObject

TARGET_FPS = 30.0
RES = 0.05




def lab_map() -> OccupancyMap:
    """An 8 m x 6 m room with one-cell walls, a pillar and a cabinet (both in the map, extruded like walls)."""
    w, h = round(8.0 / RES), round(6.0 / RES)
    data = np.full((h, w), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    data[round(1.0 / RES):round(1.3 / RES), round(6.5 / RES):round(6.8 / RES)] = OCCUPIED  # pillar
    data[round(5.4 / RES):round(5.95 / RES), round(0.8 / RES):round(2.0 / RES)] = OCCUPIED  # cabinet
    return OccupancyMap(data, RES, Pose2D(0.0, 0.0, 0.0))


def poster_image(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = np.full((300, 400, 3), 240, np.uint8)
    for _ in range(25):
        x, y = rng.integers(0, 400), rng.integers(0, 300)
        colour = tuple(int(c) for c in rng.integers(0, 255, 3))
        cv2.circle(img, (int(x), int(y)), int(rng.integers(10, 50)), colour, -1)
    cv2.putText(img, f"LAB {seed}", (30, 160), cv2.FONT_HERSHEY_SIMPLEX, 3.0, (20, 20, 20), 8)
    return img


def lab_world() -> World:
    """Ten objects of all four shapes, two of them on a table (a static obstacle), and one moving obstacle."""
    objects = (
        WorldObject("red_can", "cylinder", 2.0, 1.5, radius=0.06, height=0.25, color=(30, 30, 200)),
        WorldObject("blue_bin", "cylinder", 5.0, 1.0, radius=0.2, height=0.5, color=(180, 80, 30)),
        WorldObject("yellow_pipe", "cylinder", 1.2, 4.2, radius=0.1, height=1.0, color=(40, 200, 220)),
        WorldObject("green_box", "box", 3.5, 2.2, yaw=0.4, width=0.4, depth=0.3, height=0.3, color=(40, 160, 40)),
        WorldObject("crate", "box", 6.0, 3.0, yaw=-0.2, width=0.6, depth=0.5, height=0.5, color=(60, 120, 170)),
        WorldObject("parcel", "box", 6.3, 5.0, z=0.75, yaw=0.1, width=0.3, depth=0.2, height=0.15,
                    color=(200, 200, 60)),
        WorldObject("ball", "sphere", 3.0, 4.0, z=0.0, radius=0.12, color=(200, 60, 20)),
        WorldObject("lamp", "sphere", 6.8, 5.0, z=0.75, radius=0.08, color=(240, 240, 250)),
        WorldObject("sign_east", "poster", 7.94, 2.5, z=0.5, yaw=math.pi, width=0.8, height=0.6,
                    image=poster_image(1)),
        WorldObject("sign_north", "poster", 3.0, 5.94, z=0.6, yaw=-math.pi / 2, width=0.6, height=0.45,
                    image=poster_image(2)),
    )
    obstacles = (
        WorldObject("table", "box", 6.4, 5.0, width=1.4, depth=0.7, height=0.75, color=(70, 110, 150)),
        MovingObstacle(WorldObject("walker", "cylinder", 4.0, 0.8, radius=0.25, height=1.7, color=(90, 90, 90)),
                       (4.0, 0.8), (4.0, 5.0), 0.4),
    )
    return World(objects, obstacles)


def loop_poses(n: int) -> list[Pose2D]:
    """The robot driving an ellipse around the room's middle, looking across the room (inwards and ahead)."""
    poses = []
    for i in range(n):
        a = 2.0 * math.pi * i / n
        poses.append(Pose2D(4.0 + 2.2 * math.cos(a), 3.0 + 1.5 * math.sin(a), a + math.pi - 0.6))
    return poses


def run(camera: RGBDCamera, world: World, occ_map: OccupancyMap, poses: list[Pose2D]) -> list[float]:
    camera.render(world, occ_map, poses[0], 0.0)  # warm up caches (wall grid, poster pyramids)
    times = []
    for i, pose in enumerate(poses):
        t0 = time.perf_counter()
        camera.render(world, occ_map, pose, 0.1 * i)
        times.append(time.perf_counter() - t0)
    return times


def report(name: str, times: list[float], seen: float) -> None:
    fps = len(times) / sum(times)
    ms = [1000.0 * t for t in times]
    print(f"{name}: {fps:.1f} frames/s (target {TARGET_FPS:.0f}: {fps / TARGET_FPS:.2f}x), per frame mean "
          f"{statistics.mean(ms):.1f} ms, median {statistics.median(ms):.1f}, p95 "
          f"{sorted(ms)[int(0.95 * (len(ms) - 1))]:.1f}, max {max(ms):.1f} ms; {seen:.1f} objects in view on average")


def objects_in_view(camera: RGBDCamera, world: World, occ_map: OccupancyMap, pose: Pose2D) -> int:
    frame = camera.render(world, occ_map, pose, 0.0)
    centres = np.array([o.centre for o in world.objects])
    uv, z = frame.project(centres)
    inside = (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < frame.width) & (uv[:, 1] >= 0) & (uv[:, 1] < frame.height)
    return int(inside.sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--save", help="write the first frame's colour and depth pictures with this prefix")
    args = parser.parse_args()
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; "
          f"Python {platform.python_version()}, NumPy {np.__version__}, OpenCV {cv2.__version__}")
    occ_map, world = lab_map(), lab_world()
    camera = RGBDCamera(CameraParams(width=args.width, height=args.height))
    print(f"scene: {occ_map.width * RES:.0f} m x {occ_map.height * RES:.0f} m room, {len(world.objects)} objects, "
          f"{len(world.obstacles)} obstacles (one moving); camera {args.width}x{args.height}")
    poses = loop_poses(args.frames)
    seen = statistics.mean(objects_in_view(camera, world, occ_map, p) for p in poses[::10])
    report("driving a loop", run(camera, world, occ_map, poses), seen)
    overview = Pose2D(0.5, 0.5, math.atan2(2.6, 4.6))
    all_seen = objects_in_view(camera, world, occ_map, overview)
    report("all objects in view", run(camera, world, occ_map, [overview] * args.frames), all_seen)
    no_world = run(camera, World(), occ_map, poses)
    print(f"walls and floor only: {len(no_world) / sum(no_world):.1f} frames/s")
    if args.save:
        frame = camera.render(world, occ_map, overview, 0.0)
        cv2.imwrite(f"{args.save}_color.png", frame.color)
        depth = np.nan_to_num(frame.depth, nan=0.0)
        cv2.imwrite(f"{args.save}_depth.png", np.clip(depth / 8.0 * 255.0, 0, 255).astype(np.uint8))


if __name__ == "__main__":
    main()
