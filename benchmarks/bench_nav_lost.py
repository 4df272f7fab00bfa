"""A robot that knows it is lost: goals, collisions and amcl's worst error over seeds, for two lessons.

* ``box``: the lesson's unmapped 0.5 m box 0.15 m from two TurtleBot3-world pillars, ``--goals`` goals spread
  over the map, amcl with 5 % odometry noise. Target: at least 38 of 40 goals, no collision, no slide.
* ``kidnap``: the lost-robot room, two laps of four goals, the robot carried off at t = 20 s. Target: lost
  within 10 s, relocalised within 0.3 m, both laps completed. ``--destinations`` adds kidnaps to four more
  places of the room.
* ``symmetric``: the same kidnap in a room that a half turn maps onto itself. Target: lost within 10 s, then
  the patrol gives up saying the map looks the same from two places, having trusted no pose.
* ``corridor``: a 30 m bare corridor, two goals at its ends, the robot carried at t = 20 s to its middle (15 m
  from either end, beyond the laser's 6 m). Target: the patrol gives up saying it cannot tell where along the
  corridor it is, having trusted no pose (amcl may lose itself before the kidnap: a bare corridor spreads its
  cloud along it).
* ``--map PATH``: a kidnap on any map (the Willow Garage office in ``../shared/data/maps/willow_2010``): one lap
  of ``--map-goals`` goals spread over the map, the robot carried at t = 20 s to the next spread point. Reported:
  lost, regained (how far off) or the reason given up, and the poses and CPU time of each global search.

Run: ``.venv/bin/python benchmarks/bench_nav_lost.py --seeds 20`` (the box needs the TurtleBot3 world in
``../shared/data/maps``; it is skipped with a note when absent, and ``--box-seeds`` sets its seeds). Reported
CPU time is this process's.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import time
from pathlib import Path

from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

from navigation import amcl_global, relocalize
from navigation.amcl_global import GlobalSearchParams
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.lost_scenarios import (
    CORRIDOR_GOALS,
    CORRIDOR_KIDNAP,
    CORRIDOR_LENGTH,
    CORRIDOR_WIDTH,
    LOST_ROOM_BLOCKS,
    LOST_ROOM_GOALS,
    LOST_ROOM_KIDNAP,
    SYMMETRIC_ROOM_BLOCKS,
    SYMMETRIC_ROOM_GOALS,
    SYMMETRIC_ROOM_KIDNAP,
    box_between_pillars,
    lost_room,
    spread_goals,
)
from navigation.maps import load_map
from navigation.patrol import PatrolMachine
from navigation.people_scenarios import corridor_map
from navigation.planner import Planner
from navigation.relocalize import RelocalizeParams, schedule_kidnap
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


#: More places the kidnap carries the robot to with --destinations: open floor, beside blocks, near a wall.
DESTINATIONS = (Pose2D(5.5, 2.0, 1.0), Pose2D(3.0, 1.0, 3.0), Pose2D(2.5, 2.0, 0.5), Pose2D(3.5, 3.5, -1.0))


def kidnap_run(seed: int, to: Pose2D = LOST_ROOM_KIDNAP, symmetric: bool = False) -> str:
    blocks, goals = (SYMMETRIC_ROOM_BLOCKS, SYMMETRIC_ROOM_GOALS) if symmetric else (LOST_ROOM_BLOCKS, LOST_ROOM_GOALS)
    sim = Simulation(lost_room(blocks), goals[0], SimConfig(localization="amcl", seed=seed, **NOISY))
    schedule_kidnap(sim, 20.0, to)
    s = run_patrol(PatrolMachine(sim, list(goals), None, max_laps=2), handle_sigint=False, max_steps=20_000)
    lost = sim.events.of_type("localization_lost")
    found = sim.events.of_type("localization_regained")
    noticed = f"{lost[0]['t'] - 20.0:.1f} s" if lost else "never"
    off = "-"
    if found:
        believed, true = found[0]["believed"], found[0]["true"]
        off = f"{math.hypot(believed['x'] - true['x'], believed['y'] - true['y']):.2f} m"
    stages = "/".join(e["stage"] for e in sim.events.of_type("relocalize"))
    name = "symmetric" if symmetric else "kidnap"
    regained = f"t={found[0]['t']} s" if found else "-"
    rejected = len(sim.events.of_type("pose_rejected"))
    return (f"{name} seed {seed} to ({to.x:g}, {to.y:g}): lost after {noticed}, regained at {regained} ({off} off; "
            f"stages {stages}; {rejected} poses rejected), {s.goals_reached}/8 goals ({s.goals_aborted} aborted), "
            f"{s.collisions} collisions, {s.preempt_reason or 'completed'}")


def corridor_run(seed: int) -> str:
    """Two laps between the bare corridor's ends; at t = 20 s the robot is carried to its middle."""
    sim = Simulation(corridor_map(CORRIDOR_LENGTH, CORRIDOR_WIDTH), CORRIDOR_GOALS[0],
                     SimConfig(localization="amcl", seed=seed, **NOISY))
    schedule_kidnap(sim, 20.0, CORRIDOR_KIDNAP)
    machine = PatrolMachine(sim, list(CORRIDOR_GOALS), None, max_laps=2)
    s = run_patrol(machine, handle_sigint=False, max_steps=20_000)
    lost = sim.events.of_type("localization_lost")
    noticed = f"{lost[0]['t'] - 20.0:.1f} s" if lost else "never"
    stages = "/".join(e["stage"] for e in sim.events.of_type("relocalize"))
    trusted = len(sim.events.of_type("localization_regained"))
    rejected = [e.get("reason", "") for e in sim.events.of_type("pose_rejected")]
    return (f"corridor seed {seed}: lost after {noticed}; stages {stages}; {trusted} poses trusted, {len(rejected)} "
            f"rejected{f' (first: {rejected[0]})' if rejected else ''}; {s.goals_reached}/4 goals; "
            f"{machine.end_reason or s.preempt_reason or 'completed'}")


class SearchMeter:
    """The global searches of a run (the LOCALIZE stage's and amcl's second opinions): how many poses each scored
    and its CPU time (this process's)."""

    def __init__(self) -> None:
        self.searches: list[tuple[int, float]] = []
        self._search = amcl_global.search

    def __enter__(self) -> SearchMeter:
        def timed(pf, views, odom_now, laser, params=None):  # type: ignore[no-untyped-def]
            cpu = time.process_time()
            found = self._search(pf, views, odom_now, laser, params)
            p = params or amcl_global.GlobalSearchParams()
            self.searches.append((amcl_global.seed_count(pf, p), time.process_time() - cpu))
            return found

        relocalize.search = amcl_global.search = timed  # what Relocalize and second_opinion call
        return self

    def __exit__(self, *_exc: object) -> None:
        relocalize.search = amcl_global.search = self._search

    def describe(self) -> str:
        return ", ".join(f"{n} poses in {cpu:.2f} s CPU" for n, cpu in self.searches) or "none"


def map_kidnap_run(path: Path, seed: int, n_goals: int, fixed_seeds: int = 0) -> str:
    """One lap of goals spread over the map at ``path``; at t = 20 s the robot is carried to the next point.
    ``fixed_seeds``: every global search scores that many poses whatever the map's size (0: the default rule,
    poses per square metre of free space)."""
    occ_map = load_map(path)
    field = ObstacleField(occ_map)
    planner = Planner(field)
    points = spread_goals(planner, n_goals + 1, seed)
    goals, to = points[:n_goals], points[n_goals]
    sim = Simulation(occ_map, goals[-1], SimConfig(localization="amcl", seed=seed, **NOISY), field_=field,
                     planner=planner)
    schedule_kidnap(sim, 20.0, to)
    machine = PatrolMachine(sim, goals, None, max_laps=1)
    if fixed_seeds:
        machine.relocalize.params = RelocalizeParams(search=GlobalSearchParams(min_seeds=fixed_seeds,
                                                                               max_seeds=fixed_seeds))
    with SearchMeter() as meter:
        s = run_patrol(machine, handle_sigint=False, max_steps=30_000)
    lost = sim.events.of_type("localization_lost")
    found = sim.events.of_type("localization_regained")
    off = "-"
    if found:
        believed, true = found[0]["believed"], found[0]["true"]
        off = f"{math.hypot(believed['x'] - true['x'], believed['y'] - true['y']):.2f} m"
    noticed = f"{lost[0]['t'] - 20.0:.1f} s" if lost else "never"
    regained = f"at t={found[0]['t']} s ({off} off)" if found else "never"
    return (f"map {path.name} seed {seed} to ({to.x:.1f}, {to.y:.1f}): lost after {noticed}, regained {regained}; "
            f"searches: {meter.describe()}; "
            f"{s.goals_reached}/{len(goals)} goals, {s.preempt_reason or 'completed'}"
            + (f"; gave up: {machine.end_reason}" if machine.end_reason else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="kidnap seeds 0..N-1 (default 20)")
    parser.add_argument("--box-seeds", type=int, default=4, help="box-beside-pillars seeds (default 4)")
    parser.add_argument("--symmetric-seeds", type=int, default=4, help="symmetric-room seeds (default 4)")
    parser.add_argument("--destinations", action="store_true", help="also kidnap to four more places")
    parser.add_argument("--goals", type=int, default=40)
    parser.add_argument("--corridor-seeds", type=int, default=4, help="bare-corridor seeds (default 4)")
    parser.add_argument("--map", type=Path, help="also kidnap on this map (e.g. the Willow Garage office)")
    parser.add_argument("--map-seeds", type=int, default=2, help="seeds of the --map kidnap (default 2)")
    parser.add_argument("--map-goals", type=int, default=4, help="goals of the --map kidnap (default 4)")
    parser.add_argument("--fixed-seeds", type=int, default=0,
                        help="score this many poses in each global search of the --map kidnap, whatever the map's "
                             "size (20000: the rule before poses followed the free area)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    print(f"machine: {cpu_model()}, load {os.getloadavg()[0]:.2f}")
    cpu0 = time.process_time()
    for seed in range(args.seeds):
        print(kidnap_run(seed), flush=True)
        for to in DESTINATIONS if args.destinations else ():
            print(kidnap_run(seed, to), flush=True)
    for seed in range(args.symmetric_seeds):
        print(kidnap_run(seed, SYMMETRIC_ROOM_KIDNAP, symmetric=True), flush=True)
    for seed in range(args.corridor_seeds):
        print(corridor_run(seed), flush=True)
    if TB3.is_file():
        for seed in range(args.box_seeds):
            print(box_run(seed, args.goals))
    else:
        print(f"box: skipped, {TB3} not found")
    for seed in range(args.map_seeds if args.map else 0):
        print(map_kidnap_run(args.map, seed, args.map_goals, args.fixed_seeds), flush=True)
    print(f"CPU {time.process_time() - cpu0:.1f} s")


if __name__ == "__main__":
    main()
