"""People in corridors: the scenes the walker tests and ``benchmarks/bench_nav_people.py`` share.

A corridor is where a robot and a person cannot simply keep out of each other's way, so it is where a
walker that passes through the robot, a controller that drives into a person, or a clear-costmap recovery
that forgets a person still standing there shows up. Two scenes: a generated straight corridor (always
available) and a straight stretch of corridor found on a real map (the Willow Garage office).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .costmap import ObstacleField
from .geometry import Pose2D
from .maps import FREE, OCCUPIED, OccupancyMap
from .move_base import GoalStatus
from .simulation import Simulation
from .world import MovingObstacle, WorldObject

#: A person seen from above, as the world file would declare one (metres).
WALKER_RADIUS = 0.25
WALKER_HEIGHT = 1.7


def corridor_map(length: float = 12.0, width: float = 2.0, resolution: float = 0.05, doors: float = 0.0
                 ) -> OccupancyMap:
    """A straight corridor along x, its floor from (0, 0) to (length, width), walls one cell thick all round.

    With ``doors`` (metres apart), 0.8 m wide door recesses 0.25 m deep alternate between the two walls, as in
    an office corridor: without them a long corridor looks the same all along, and amcl cannot tell where
    along it the robot is.
    """
    recess = round(0.25 / resolution) if doors > 0 else 0
    w, h = round(length / resolution), round(width / resolution)
    data = np.full((h + 2 * recess, w), OCCUPIED, np.int8)
    data[recess + 1:recess + h - 1, 1:-1] = FREE
    if doors > 0:
        door = round(0.8 / resolution)
        for k, x in enumerate(np.arange(doors / 2.0, length - 0.8, doors)):
            i = round(x / resolution)
            rows = slice(1, recess + 1) if k % 2 == 0 else slice(recess + h - 1, h + 2 * recess - 1)
            data[rows, i:i + door] = FREE
    return OccupancyMap(data, resolution, Pose2D(0.0, -recess * resolution, 0.0))


def walker(name: str, start: tuple[float, float], end: tuple[float, float], speed: float,
           avoid: str = "stop") -> MovingObstacle:
    """A person walking back and forth between ``start`` and ``end``."""
    body = WorldObject(name, "cylinder", start[0], start[1], radius=WALKER_RADIUS, height=WALKER_HEIGHT,
                       color=(90, 90, 90))
    return MovingObstacle(body, start, end, speed, avoid)


@dataclass(frozen=True)
class Corridor:
    """A straight stretch of free floor: its middle, direction (radians) and half its usable length."""

    x: float
    y: float
    heading: float
    half_length: float
    half_width: float

    def point(self, along: float, across: float = 0.0) -> tuple[float, float]:
        c, s = math.cos(self.heading), math.sin(self.heading)
        return self.x + along * c - across * s, self.y + along * s + across * c


def pacing_walkers(corridor: Corridor, rng: np.random.Generator, count: int = 2, avoid: str = "stop"
                   ) -> tuple[MovingObstacle, ...]:
    """``count`` walkers from seeded random places, each pacing between a point in the corridor's first half and
    one in its second at 0.3-0.6 m/s, kept 0.45 m off its walls: the people benchmark's scene."""
    half, side = corridor.half_length, max(0.0, corridor.half_width - 0.45)
    return tuple(walker(f"walker_{k}", corridor.point(rng.uniform(-half + 0.5, -0.5), rng.uniform(-side, side)),
                        corridor.point(rng.uniform(0.5, half - 0.5), rng.uniform(-side, side)),
                        float(rng.uniform(0.3, 0.6)), avoid) for k in range(count))


def corridor_ends(corridor: Corridor) -> tuple[Pose2D, Pose2D]:
    """The two goals 0.3 m short of the corridor's ends, each facing on out of it: a robot sent between them
    drives its whole length."""
    half = corridor.half_length
    return (Pose2D(*corridor.point(half - 0.3), corridor.heading),
            Pose2D(*corridor.point(-half + 0.3), corridor.heading + math.pi))


def find_corridor(field: ObstacleField, half_length: float = 2.5, min_half_width: float = 0.55,
                  max_half_width: float = 1.1) -> Corridor | None:
    """The first straight stretch (by heading, then row by row) whose centre line keeps between
    ``min_half_width`` and ``max_half_width`` from the walls for ``half_length`` each way: a corridor a
    robot and a walker both fit in, but not side by side with room to spare."""
    m = field.map
    step = max(1, round(0.3 / m.resolution))
    clear = field.dist[1:-1, 1:-1] - 0.5 * m.resolution
    rows, cols = np.nonzero((clear[::step, ::step] >= min_half_width) & (clear[::step, ::step] <= max_half_width))
    if not len(rows):
        return None
    xs, ys = m.cell_to_world(cols * step, rows * step)
    xs, ys = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    offsets = np.linspace(-half_length, half_length, max(3, round(2 * half_length / m.resolution)))
    for heading in np.radians(np.arange(0.0, 180.0, 2.5)):
        px = xs[:, None] + offsets[None, :] * math.cos(heading)
        py = ys[:, None] + offsets[None, :] * math.sin(heading)
        gx, gy = m.world_to_grid(px, py)
        i = np.clip(np.floor(gx).astype(np.int64) + 1, 0, field.width - 1)
        j = np.clip(np.floor(gy).astype(np.int64) + 1, 0, field.height - 1)
        c = field.dist[j, i] - 0.5 * m.resolution
        ok = np.flatnonzero((c.min(axis=1) >= min_half_width) & (c.max(axis=1) <= max_half_width))
        if len(ok):
            k = int(ok[0])
            return Corridor(float(xs[k]), float(ys[k]), float(heading), half_length, float(c[k].min()))
    return None


def drive_goals(sim: Simulation, goals: Sequence[Pose2D], limit: float = 600.0) -> list[tuple[GoalStatus, str]]:
    """Send the goals one after another, each when the last one's result is in: their (status, text).

    A goal still without a result after ``limit`` simulated seconds is cancelled (a hang, not an answer).
    """
    results: list[tuple[GoalStatus, str]] = []
    for k, goal in enumerate(goals):
        got: list[tuple[GoalStatus, str]] = []
        sim.move_base.send_goal(goal, lambda s, t, got=got: got.append((s, t)), name=f"goal_{k}")
        end = sim.clock.now + limit
        while not got and sim.clock.now < end:
            sim.step()
        if not got:
            sim.move_base.cancel_goal(f"no result within {limit:g} s")
            sim.step()
        results.append(got[0] if got else (GoalStatus.PREEMPTED, f"no result within {limit:g} s"))
    return results
