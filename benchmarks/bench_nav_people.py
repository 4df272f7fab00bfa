"""People in corridors: collisions per 20 goals and how every goal ended, over seeds.

    .venv/bin/python benchmarks/bench_nav_people.py [--seeds 0-9] [--goals 20] [--walkers 2]
        [--avoid stop,sidestep] [--localization exact,amcl] [--recoveries default,patient] [--trail-check] [--willow]
        [--shared-data DIR]

Each run: a 12 m x 2 m corridor with a door recess every 2.5 m (or, with ``--willow``, a straight stretch of
corridor on the Willow Garage map), walkers going back and forth along it at 0.3-0.6 m/s from seeded random
places, and the robot sent
from one end to the other ``--goals`` times (amcl with 5 % odometry noise). Target: at most 1 collision per
20 goals, and every goal reached or aborted with a reason (a goal without a result is a failure).
``--avoid none`` gives the scripted walkers of old, blind to the robot, for comparison. ``--recoveries``
compares move_base's recovery orders: ``default`` (clear the costmap, rotate, back up) and ``patient`` (a
wait of up to ``MoveBaseParams.patience`` seconds for what stands in the way to move, after clearing).
``--trail-check`` also counts, per row, the recovery starts and wait seconds at which the robot had no plan round
all the marks but would have had one round the marks on a walker's body alone: held up by trails, the marks of
where a walker was (slower: two plans a second while waiting).
Simulated time only; the CPU seconds are this process's.
"""

from __future__ import annotations

import argparse
import collections
import itertools
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

from navigation.costmap import ObstacleField
from navigation.maps import OccupancyMap, load_map
from navigation.move_base import PATIENT_RECOVERY_BEHAVIOURS, RECOVERY_BEHAVIOURS, GoalStatus, MoveBaseParams
from navigation.people_scenarios import (
    Corridor,
    corridor_ends,
    corridor_map,
    drive_goals,
    find_corridor,
    pacing_walkers,
)
from navigation.planner import Planner
from navigation.simulation import SimConfig, Simulation
from navigation.world import World

ROOT = Path(__file__).resolve().parents[1]
WILLOW = "maps/willow_2010/willow-2010-02-18-0.10.yaml"
TARGET_PER_20 = 1.0
RECOVERIES = {"default": RECOVERY_BEHAVIOURS, "patient": PATIENT_RECOVERY_BEHAVIOURS}


def seeds_of(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-", 1)
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def run(occ_map: OccupancyMap, corridor: Corridor, seed: int, goals: int, walkers: int, avoid: str,
        localization: str, recoveries: str = "default", trail_check: bool = False) -> dict:
    """One seeded run: walkers placed along the corridor, the robot driven end to end ``goals`` times."""
    people = pacing_walkers(corridor, np.random.default_rng(seed), walkers, avoid)
    ends = corridor_ends(corridor)
    noise = 0.05 if localization == "amcl" else 0.0
    config = SimConfig(seed=seed, localization=localization, odom_linear_noise=noise, odom_angular_noise=noise,
                       move_base=MoveBaseParams(recovery_behaviours=RECOVERIES[recoveries]))
    sim = Simulation(occ_map, ends[1], config, world=World(obstacles=people))
    trails = TrailCheck(sim) if trail_check else None
    if trails is not None:
        step = sim.step

        def checked_step() -> None:
            step()
            trails()
        sim.step = checked_step  # type: ignore[method-assign]
    results = drive_goals(sim, [ends[k % 2] for k in range(goals)])
    return {"collisions": sim.collisions, "results": results, "sim_time": sim.clock.now,
            "by": collections.Counter(e["by"] for e in sim.events.of_type("collision")),
            "trails": trails.counts if trails is not None else collections.Counter()}


class TrailCheck:
    """At every recovery start and every simulated second of a wait, plan twice: round all the marks, and round
    only those on a walker's body (within 0.15 m of where a walker really is). A plan round the second but not
    the first means the robot is held up by trails alone: marks where a walker was, not where one is."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.counts: collections.Counter[str] = collections.Counter()
        self._behaviour: str | None = None
        self._next = 0.0

    def __call__(self) -> None:
        mb = self.sim.move_base
        behaviour = mb.recovering if mb.active else None
        started = behaviour is not None and behaviour != self._behaviour
        self._behaviour = behaviour
        if behaviour is None or mb.costmap.empty:
            return
        if started or (behaviour == "wait" and self.sim.clock.now >= self._next - 1e-9):
            kind = "recovery starts" if started else "wait seconds"
            self.counts[kind] += 1
            self.counts[kind + " held by trails"] += int(self._held_by_trails())
            self._next = self.sim.clock.now + 1.0

    def _held_by_trails(self) -> bool:
        sim, mb = self.sim, self.sim.move_base
        assert mb.goal is not None and sim.world is not None
        pts = mb.costmap.points()
        on_body = np.zeros(len(pts), dtype=bool)
        for o in sim.world.solids_at(sim.clock.now):
            on_body |= np.hypot(pts[:, 0] - o.x, pts[:, 1] - o.y) - o.radius < 0.15
        ok = []
        for keep in (np.ones(len(pts), dtype=bool), on_body):
            marks = mb.costmap.subset(keep)
            planner = Planner(ObstacleField(marks.as_map()), replace(sim.planner.params, landmarks=0))
            ok.append(planner.plan(sim.pose_estimate(), mb.goal.pose, mb.follower_params.xy_tolerance).ok)
        return not ok[0] and ok[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-9", help="seeds, as 0-9 or 1,4,7 (default 0-9)")
    parser.add_argument("--goals", type=int, default=20, help="goals per run (default 20)")
    parser.add_argument("--walkers", type=int, default=2, help="walkers in the corridor (default 2)")
    parser.add_argument("--avoid", default="stop,sidestep", help="walker models to compare (stop, sidestep, none)")
    parser.add_argument("--localization", default="exact,amcl", help="exact, amcl or both (default both)")
    parser.add_argument("--recoveries", default="default",
                        help=f"recovery orders to compare, of {', '.join(RECOVERIES)} (default: default)")
    parser.add_argument("--trail-check", action="store_true",
                        help="also count recovery starts and wait seconds held up by trails alone (slower)")
    parser.add_argument("--willow", action="store_true", help="a corridor of the Willow Garage map (shared data)")
    parser.add_argument("--shared-data", type=Path,
                        default=Path(os.environ.get("OBJREC_SHARED_DATA", ROOT.parent / "shared" / "data")))
    args = parser.parse_args()
    if args.willow:
        path = args.shared_data / WILLOW
        if not path.is_file():
            raise SystemExit(f"no Willow map at {path}: pass --shared-data or leave out --willow")
        occ_map = load_map(path)
        corridor = find_corridor(ObstacleField(occ_map), half_length=5.0, max_half_width=1.0)
        if corridor is None:
            raise SystemExit(f"{path}: no straight corridor found")
        scene = f"Willow corridor at ({corridor.x:.1f}, {corridor.y:.1f}), {2 * corridor.half_length:g} m"
    else:
        occ_map = corridor_map(12.0, 2.0, doors=2.5)
        corridor = Corridor(6.0, 1.0, 0.0, 5.5, 0.95)
        scene = "generated corridor 12 m x 2 m, a door recess every 2.5 m"
    seeds = seeds_of(args.seeds)
    print(f"{scene}; {args.walkers} walkers; {args.goals} goals x {len(seeds)} seeds ({args.seeds}); "
          f"CPU: {cpu_model()}; load: {os.getloadavg()[0]:.2f}")
    print(f"{'walkers':9} {'pose':6} {'recovery':8} {'goals':>6} {'reached':>8} {'aborted':>8} {'collisions':>10} "
          f"{'per 20':>7} {'sim s':>7} {'CPU s':>6}  abort reasons")
    for avoid, localization, recoveries in itertools.product(args.avoid.split(","), args.localization.split(","),
                                                             args.recoveries.split(",")):
        cpu = time.process_time()
        total, reached, aborted, collisions, sim_time = 0, 0, 0, 0, 0.0
        reasons: collections.Counter[str] = collections.Counter()
        unanswered = 0
        trails: collections.Counter[str] = collections.Counter()
        for seed in seeds:
            out = run(occ_map, corridor, seed, args.goals, args.walkers, avoid, localization, recoveries,
                      args.trail_check)
            trails.update(out["trails"])
            collisions += out["collisions"]
            sim_time += out["sim_time"]
            for status, text in out["results"]:
                total += 1
                reached += status == GoalStatus.SUCCEEDED
                if status == GoalStatus.ABORTED:
                    aborted += 1
                    reasons[text.split(" (after")[0]] += 1
                elif status != GoalStatus.SUCCEEDED or not text:
                    unanswered += 1
        per20 = 20.0 * collisions / max(total, 1)
        verdict = "ok" if per20 <= TARGET_PER_20 and not unanswered else "MISSED"
        print(f"{avoid:9} {localization:6} {recoveries:8} {total:6d} {reached:8d} {aborted:8d} {collisions:10d} "
              f"{per20:7.2f} {sim_time:7.0f} {time.process_time() - cpu:6.1f}  {dict(reasons) or '-'} [{verdict}]",
              flush=True)
        if args.trail_check:
            print(f"{'':25} held up by trails alone: {trails['recovery starts held by trails']} of "
                  f"{trails['recovery starts']} recovery starts, {trails['wait seconds held by trails']} of "
                  f"{trails['wait seconds']} wait seconds", flush=True)


if __name__ == "__main__":
    main()
