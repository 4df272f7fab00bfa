"""A robot that knows it is lost: goals, collisions and amcl's worst error over seeds, for two lessons.

* ``box``: the issue's unmapped 0.5 m box 0.15 m from two TurtleBot3-world pillars, ``--goals`` goals spread
  over the map, amcl with 5 % odometry noise. Target: at least 38 of 40 goals, no collision, no slide.
* ``kidnap``: the lost-robot room, two laps of four goals, the robot carried off at t = 20 s. Target: lost
  within 10 s, relocalised within 0.3 m, both laps completed.

Run: ``.venv/bin/python benchmarks/bench_nav_lost.py --seeds 8`` (the box needs the TurtleBot3 world in
``../shared/data/maps``; it is skipped with a note when absent). Reported CPU time is this process's.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import time
from pathlib import Path

from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

from navigation.costmap import ObstacleField
from navigation.lost_scenarios import (
    LOST_ROOM_GOALS,
    LOST_ROOM_KIDNAP,
    box_between_pillars,
    lost_room,
    spread_goals,
)
from navigation.maps import load_map
from navigation.patrol import PatrolMachine
from navigation.planner import Planner
from navigation.relocalize import schedule_kidnap
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation
from navigation.world import World

NOISY = {"odom_linear_noise": 0.05, "odom_angular_noise": 0.05}
TB3 = Path(os.environ.get("OBJREC_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data")) \
    / "maps" / "turtlebot3_world" / "map.yaml"


def box_run(seed: int, n_goals: int) -> str:
    occ_map = load_map(TB3)
    world = World(obstacles=(box_between_pillars(occ_map),))
    field = ObstacleField(occ_map)
    planner = Planner(field)
    goals = [g for g in spread_goals(planner, n_goals + 4, seed) if not world.collides(g.x, g.y, 0.35)][:n_goals]
    sim = Simulation(occ_map, goals[-1], SimConfig(localization="amcl", seed=seed, **NOISY), field_=field,
                     planner=planner, world=world)
    s = run_patrol(PatrolMachine(sim, goals, None, max_laps=1), handle_sigint=False)
    return (f"box     seed {seed}: {s.goals_reached}/{len(goals)} goals, {s.collisions} collisions, amcl error max "
            f"{s.localization_error_max:.3f} m, lost {s.localization_lost}")


def kidnap_run(seed: int) -> str:
    sim = Simulation(lost_room(), LOST_ROOM_GOALS[0], SimConfig(localization="amcl", seed=seed, **NOISY))
    schedule_kidnap(sim, 20.0, LOST_ROOM_KIDNAP)
    s = run_patrol(PatrolMachine(sim, list(LOST_ROOM_GOALS), None, max_laps=2), handle_sigint=False,
                   max_steps=20_000)
    lost = sim.events.of_type("localization_lost")
    found = sim.events.of_type("localization_regained")
    noticed = f"{lost[0]['t'] - 20.0:.1f} s" if lost else "never"
    off = "-"
    if found:
        believed, true = found[0]["believed"], found[0]["true"]
        off = f"{math.hypot(believed['x'] - true['x'], believed['y'] - true['y']):.2f} m"
    stages = "/".join(e["stage"] for e in sim.events.of_type("relocalize"))
    return (f"kidnap  seed {seed}: lost after {noticed}, regained at t={found[0]['t'] if found else '-'} s "
            f"({off} off; stages {stages}), {s.goals_reached}/8 goals ({s.goals_aborted} aborted), "
            f"{s.collisions} collisions, "
            f"{s.preempt_reason or 'completed'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--goals", type=int, default=40)
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    print(f"machine: {cpu_model()}, load {os.getloadavg()[0]:.2f}")
    cpu0 = time.process_time()
    for seed in range(args.seeds):
        print(kidnap_run(seed))
    if TB3.is_file():
        for seed in range(args.seeds):
            print(box_run(seed, args.goals))
    else:
        print(f"box: skipped, {TB3} not found")
    print(f"CPU {time.process_time() - cpu0:.1f} s")


if __name__ == "__main__":
    main()
