"""A* on the inflated costmap: clearance, doorways, unreachable and blocked goals, rotated maps."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from navigation.planner import Planner, PlannerParams

RES = 0.05


def grid(width: float, height: float, boxes=(), origin: Pose2D | None = None) -> OccupancyMap:
    w, h = round(width / RES), round(height / RES)
    data = np.full((h, w), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    for x0, y0, x1, y1, *value in boxes:
        data[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = value[0] if value else OCCUPIED
    return OccupancyMap(data, RES, origin or Pose2D(0.0, 0.0, 0.0))


def planner_for(m: OccupancyMap, **params) -> Planner:
    return Planner(ObstacleField(m), PlannerParams(**params))


def _min_clearance(planner: Planner, path: np.ndarray) -> float:
    worst = math.inf
    for p, q in itertools.pairwise(path):
        for t in np.linspace(0, 1, 25):
            worst = min(worst, planner.field.clearance(*(p + t * (q - p))))
    return worst


def test_open_room_gives_a_straight_path():
    planner = planner_for(grid(6, 4))
    plan = planner.plan(Pose2D(1.0, 2.0), Pose2D(5.0, 2.0))
    assert plan.ok
    assert plan.length == pytest.approx(4.0, abs=0.06)
    assert len(plan.path) == 2  # the shortcutting leaves start and goal only
    assert tuple(plan.path[0]) == (1.0, 2.0)


def test_path_goes_round_an_obstacle_keeping_its_clearance():
    planner = planner_for(grid(6, 4, boxes=[(2.5, 0.0, 3.0, 3.0)]))
    plan = planner.plan(Pose2D(1.0, 1.0), Pose2D(5.0, 1.0))
    assert plan.ok
    assert plan.path[:, 1].max() > 3.0 + 0.28 - RES  # over the top of the wall
    assert _min_clearance(planner, plan.path) >= 0.28 - 0.75 * RES
    # Shortest way round the inflated wall: up to its corner, across its top, down to the goal.
    inflated_top, left, right = 3.0 + 0.28, 2.5 - 0.28, 3.0 + 0.28
    shortest = (math.hypot(left - 1.0, inflated_top - 1.0) + (right - left)
                + math.hypot(5.0 - right, inflated_top - 1.0))
    assert shortest - RES <= plan.length <= 1.1 * shortest


@pytest.mark.parametrize(("gap", "ok"), [(0.50, False), (0.70, True)])
def test_doorway_must_be_wider_than_the_inflated_robot(gap, ok):
    lo, hi = 2.0 - gap / 2, 2.0 + gap / 2
    m = grid(6, 4, boxes=[(2.9, 0.0, 3.1, lo), (2.9, hi, 3.1, 4.0)])
    plan = planner_for(m).plan(Pose2D(1.0, 2.0), Pose2D(5.0, 2.0))
    assert plan.ok is ok
    if not ok:
        assert plan.reason.startswith(
            "no path: the goal lies in a region the start cannot reach: the narrowest passage")


def test_goal_in_an_obstacle_and_goal_just_inside_the_inflation():
    planner = planner_for(grid(6, 4, boxes=[(2.5, 1.5, 3.5, 2.5)]))
    plan = planner.plan(Pose2D(1.0, 1.0), Pose2D(3.0, 2.0))
    assert not plan.ok and plan.reason == "goal is in an obstacle"
    # 0.2 m from the box: inside the 0.28 m inflation, but a free cell lies within the 0.15 m tolerance.
    near = Pose2D(3.0, 2.5 + 0.2)
    plan = planner.plan(Pose2D(1.0, 1.0), near, goal_tolerance=0.15)
    assert plan.ok
    assert math.hypot(*(plan.path[-1] - (near.x, near.y))) <= 0.15


def test_start_against_a_wall_escapes_the_inflation():
    planner = planner_for(grid(6, 4))
    start = Pose2D(0.05 + 0.19, 2.0)  # one centimetre clear of the west wall
    plan = planner.plan(start, Pose2D(4.0, 2.0))
    assert plan.ok
    assert planner.plan(Pose2D(0.1, 2.0), Pose2D(4.0, 2.0)).reason == "start is in an obstacle"


def test_start_and_goal_off_the_map():
    planner = planner_for(grid(6, 4))
    assert planner.plan(Pose2D(-2, 1), Pose2D(3, 2)).reason == "start is outside the map"
    assert planner.plan(Pose2D(1, 1), Pose2D(30, 2)).reason == "goal is outside the map"


def test_unknown_space_is_not_entered():
    m = grid(6, 4, boxes=[(2.5, 0.0, 3.5, 3.2, UNKNOWN)])
    plan = planner_for(m).plan(Pose2D(1.0, 1.0), Pose2D(5.0, 1.0))
    assert plan.ok
    assert plan.path[:, 1].max() > 3.2 + 0.28 - RES


def test_rotated_map_origin():
    origin = Pose2D(10.0, -3.0, 0.7)
    m = grid(6, 4, boxes=[(2.5, 0.0, 3.0, 3.0)], origin=origin)
    planner = planner_for(m)
    start, goal = Pose2D(*m.grid_to_world(1.0 / RES, 1.0 / RES)), Pose2D(*m.grid_to_world(5.0 / RES, 1.0 / RES))
    plan = planner.plan(start, goal)
    assert plan.ok
    assert _min_clearance(planner, plan.path) >= 0.28 - 0.75 * RES
    # In grid coordinates the path climbs over the wall, as in the unrotated case.
    tops = [m.world_to_grid(x, y)[1] * RES for x, y in plan.path]
    assert max(tops) > 3.0 + 0.28 - RES


def test_inflation_margin_is_a_parameter():
    m = grid(6, 4, boxes=[(2.9, 0.0, 3.1, 1.6), (2.9, 2.4, 3.1, 4.0)])  # a 0.8 m doorway
    assert planner_for(m, inflation_margin=0.10).plan(Pose2D(1, 2), Pose2D(5, 2)).ok
    assert not planner_for(m, inflation_margin=0.25).plan(Pose2D(1, 2), Pose2D(5, 2)).ok


def test_landmark_heuristic_finds_the_same_paths_with_fewer_expansions():
    # A comb of walls: the way from one end to the other zigzags, which the straight line hides.
    teeth = [(x, 0.0 if k % 2 else 1.2, x + 0.2, 4.8 if k % 2 else 6.0) for k, x in enumerate(np.arange(1.5, 9, 1.5))]
    m = grid(10, 6, boxes=teeth)
    plain = planner_for(m, landmarks=0)
    alt = planner_for(m, landmarks=4, landmark_min_cells=0)
    assert len(alt._landmarks) == 4 and plain._landmarks == []
    a, b = plain.plan(Pose2D(0.6, 3.0), Pose2D(9.4, 3.0)), alt.plan(Pose2D(0.6, 3.0), Pose2D(9.4, 3.0))
    assert a.ok and b.ok
    assert b.length == pytest.approx(a.length, rel=0.05)
    assert b.expansions < 0.5 * a.expansions
    assert _min_clearance(alt, b.path) >= 0.28 - 0.75 * RES
