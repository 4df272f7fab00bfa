"""Patrols on real gmapping maps: the TurtleBot3 world and the Willow Garage office."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from navigation.costmap import ObstacleField
from navigation.lost_scenarios import spread_goals
from navigation.maps import load_map
from navigation.patrol import PatrolMachine
from navigation.planner import Planner
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation

pytestmark = pytest.mark.realdata

MAPS = {
    "turtlebot3_world": "maps/turtlebot3_world/map.yaml",
    "willow": "maps/willow_2010/willow-2010-02-18-0.10.yaml",
}


@pytest.mark.parametrize(("name", "n_goals", "laps", "seed"),
                         [("turtlebot3_world", 6, 2, 0), ("turtlebot3_world", 8, 1, 7), ("willow", 6, 1, 0),
                          ("willow", 8, 1, 5)])
def test_patrol_completes_its_laps_without_collision(shared_data, name, n_goals, laps, seed):
    occ_map = load_map(shared_data / MAPS[name])
    field = ObstacleField(occ_map)
    planner = Planner(field)
    goals = spread_goals(planner, n_goals, seed)
    sim = Simulation(occ_map, goals[-1], SimConfig(), field_=field, planner=planner)
    machine = PatrolMachine(sim, goals, station_pose=None, max_laps=laps)
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered[-1] == "SHUTDOWN" and machine.outcome == "shutdown"
    assert summary.laps == laps
    assert summary.goals_reached == laps * n_goals
    assert summary.goals_aborted == 0
    assert summary.collisions == 0
    assert not sim.events.of_type("recovery")
    # Every goal was really reached: the robot stood within tolerance when each result came in.
    reached = sim.events.of_type("goal_result")
    assert len(reached) == laps * n_goals
    for result in reached:
        goal = goals[int(result["name"].split("_")[1])]
        robot = result["robot"]
        assert np.hypot(robot["x"] - goal.x, robot["y"] - goal.y) <= 0.15
        assert abs(np.remainder(robot["yaw"] - goal.yaw + np.pi, 2 * np.pi) - np.pi) <= 0.3
    # The patrol crossed the map: at least the straight-line tour length was driven.
    tour = sum(goals[k].distance_to(goals[k - 1]) for k in range(1, n_goals))
    assert summary.distance > tour


@pytest.mark.parametrize("name", list(MAPS))
def test_plans_keep_clear_of_inflated_obstacles(shared_data, name):
    occ_map = load_map(shared_data / MAPS[name])
    planner = Planner(ObstacleField(occ_map))
    goals = spread_goals(planner, 6, 11)
    for a, b in itertools.pairwise(goals):
        plan = planner.plan(a, b)
        assert plan.ok, plan.reason
        # Sample the path densely: every point keeps the robot radius + margin from obstacles.
        for p, q in zip(plan.path[:-1], plan.path[1:], strict=True):
            for t in np.linspace(0.0, 1.0, 20):
                x, y = p + t * (q - p)
                assert planner.field.clearance(x, y) >= planner.inflation - 0.75 * occ_map.resolution
        assert np.hypot(*(plan.path[-1] - (b.x, b.y))) <= 0.15
