"""The kidnapped robot on many seeds and places, the full-turn global search, its second opinion on a pose the
filter wants to trust again, and a symmetric room where the map cannot tell and the robot says so."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navigation.amcl_global import (
    GlobalSearchParams,
    ambiguity,
    latest_turn,
    search,
    second_opinion,
    yaw_covered,
)
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.laser import LaserParams, cast_scan
from navigation.localization import AmclParams, ParticleFilter, ScanView, compose
from navigation.lost_scenarios import (
    LOST_ROOM_BLOCKS,
    LOST_ROOM_GOALS,
    LOST_ROOM_KIDNAP,
    SYMMETRIC_ROOM_BLOCKS,
    SYMMETRIC_ROOM_GOALS,
    SYMMETRIC_ROOM_KIDNAP,
    lost_room,
    twin,
)
from navigation.patrol import LOCALIZE, PatrolMachine
from navigation.relocalize import schedule_kidnap
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation

NOISY = {"odom_linear_noise": 0.05, "odom_angular_noise": 0.05}
LASER = LaserParams(beams=30)
KIDNAP_AT = 20.0


def off(event: dict) -> float:
    return math.hypot(event["believed"]["x"] - event["true"]["x"], event["believed"]["y"] - event["true"]["y"])


def kidnapped(seed: int, to: Pose2D, symmetric: bool = False) -> tuple[Simulation, PatrolMachine]:
    blocks, goals = (SYMMETRIC_ROOM_BLOCKS, SYMMETRIC_ROOM_GOALS) if symmetric else (LOST_ROOM_BLOCKS, LOST_ROOM_GOALS)
    sim = Simulation(lost_room(blocks), goals[0], SimConfig(localization="amcl", seed=seed, **NOISY))
    schedule_kidnap(sim, KIDNAP_AT, to)
    machine = PatrolMachine(sim, list(goals), None, max_laps=2)
    run_patrol(machine, handle_sigint=False, max_steps=20_000)
    return sim, machine


def turn_of_views(field: ObstacleField, start: Pose2D, n: int = 12) -> tuple[list[ScanView], Pose2D]:
    """Scans cast from ``start`` while turning on the spot, every 30 degrees; and the odometry pose after them."""
    views = []
    for k in range(n):
        odom = Pose2D(0.0, 0.0, k * math.tau / n)
        views.append(ScanView(float(k), odom, cast_scan(field, compose(start, odom), LASER)))
    return views, views[-1].odom


# -- the patrol ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("seed", "to"), [
    (3, LOST_ROOM_KIDNAP), (11, LOST_ROOM_KIDNAP), (13, LOST_ROOM_KIDNAP), (16, LOST_ROOM_KIDNAP),
    (0, Pose2D(2.5, 2.0, 0.5)), (0, Pose2D(3.5, 3.5, -1.0)), (2, Pose2D(5.5, 2.0, 1.0)),
])
def test_a_kidnap_is_noticed_the_robot_relocalises_on_the_right_place_and_completes_its_patrol(seed, to):
    sim, machine = kidnapped(seed, to)
    lost = sim.events.of_type("localization_lost")
    assert lost and 0 < lost[0]["t"] - KIDNAP_AT <= 10.0  # noticed within 10 s of simulated time
    assert LOCALIZE in machine.entered
    found = sim.events.of_type("localization_regained")
    assert found and all(off(e) < 0.3 for e in found)  # never trusted a wrong pose
    s = machine.stats
    assert machine.preempt_reason == "" and s.laps == 2 and s.goals_reached == 8 and s.goals_aborted == 0
    assert sim.collisions == 0


def test_a_pose_that_only_looks_right_one_scan_at_a_time_is_rejected_before_it_is_trusted():
    # Carried next to a block, the cloud as it was slides onto a place 1.2 m away whose narrow scans fit: the
    # full turn's second opinion turns it down, and the global search finds the robot.
    sim, _ = kidnapped(0, Pose2D(2.5, 2.0, 0.5))
    rejected = sim.events.of_type("pose_rejected")
    assert rejected and all(off(e) > 0.5 for e in rejected)
    assert all(e["t"] < sim.events.of_type("localization_regained")[0]["t"] for e in rejected)
    assert [e["stage"] for e in sim.events.of_type("relocalize")] == ["scan", "local", "global"]
    (searched,) = sim.events.of_type("global_search")
    best, runner_up = searched["hypotheses"][:2]
    assert best["agreement"] >= 0.95 and runner_up["agreement"] <= 0.85


@pytest.mark.parametrize("seed", [0, 1])
def test_in_a_symmetric_room_the_robot_says_the_map_cannot_tell_and_drives_on_no_guess(seed):
    sim, machine = kidnapped(seed, SYMMETRIC_ROOM_KIDNAP, symmetric=True)
    lost = sim.events.of_type("localization_lost")
    assert lost and 0 < lost[0]["t"] - KIDNAP_AT <= 10.0
    assert machine.entered[-2:] == [LOCALIZE, "SHUTDOWN"]
    reason = machine.end_reason
    assert reason.startswith("localization lost: no confident pose after scan, local, global (the map looks the "
                             "same from (") and reason.endswith("it cannot tell where the robot is)")
    assert not sim.events.of_type("localization_regained")
    # The two places named are where the robot stands and its twin across the room.
    (searched,) = sim.events.of_type("global_search")
    truth = sim.robot.pose
    named = [Pose2D(h["x"], h["y"], h["yaw"]) for h in searched["hypotheses"][:2]]
    assert sorted(min(p.distance_to(truth), p.distance_to(twin(truth))) for p in named)[-1] < 0.5
    assert min(p.distance_to(truth) for p in named) < 0.5 and min(p.distance_to(twin(truth)) for p in named) < 0.5
    assert all(h["agreement"] >= 0.9 for h in searched["hypotheses"][:2])
    # It stood and turned where it was carried: no goal reached, no metre driven on either guess.
    kidnap = sim.events.of_type("kidnap")[0]
    assert not [r for r in sim.events.of_type("goal_result") if r["t"] > kidnap["t"] and r["status"] == "SUCCEEDED"]
    assert truth.distance_to(Pose2D(**kidnap["to"])) < 0.6 and sim.collisions == 0


# -- the search ----------------------------------------------------------------------------------------------

def filter_on(blocks: tuple[tuple[float, float, float, float], ...] | None = None) -> ParticleFilter:
    room = lost_room() if blocks is None else lost_room(blocks)
    return ParticleFilter(ObstacleField(room), AmclParams(), np.random.default_rng(7))


def test_a_full_turn_finds_the_robot_anywhere_in_the_room_and_nowhere_else_fits():
    pf = filter_on()
    for truth in (Pose2D(1.2, 3.3, 0.0), Pose2D(5.5, 2.0, 1.0), Pose2D(3.0, 1.0, 3.0)):
        views, odom = turn_of_views(pf.field, truth)
        now = compose(truth, odom)
        found = search(pf, views, odom, LASER)
        best = found[0]
        assert best.pose.distance_to(now) < 0.08 and abs(math.remainder(best.pose.yaw - now.yaw, math.tau)) < 0.05
        assert best.agreement >= 0.95
        assert ambiguity(found, GlobalSearchParams()) is None
        assert len(found) == 1 or found[1].agreement < best.agreement - GlobalSearchParams().ambiguity_margin
        assert second_opinion(pf, views, odom, LASER, now) == ""
        wrong = Pose2D(7.0 - now.x, 4.0 - now.y, now.yaw + math.pi)  # where a half turn of the room puts it
        assert second_opinion(pf, views, odom, LASER, wrong) != ""


def test_in_a_symmetric_room_the_search_returns_both_places_as_equally_good():
    pf = filter_on(SYMMETRIC_ROOM_BLOCKS)
    truth = Pose2D(2.2, 3.2, 0.5)
    views, odom = turn_of_views(pf.field, truth)
    now = compose(truth, odom)
    found = search(pf, views, odom, LASER)
    other = ambiguity(found, GlobalSearchParams())
    assert other is not None
    pair = [found[0].pose, other.pose]
    assert min(p.distance_to(now) for p in pair) < 0.1 and min(p.distance_to(twin(now)) for p in pair) < 0.1
    assert second_opinion(pf, views, odom, LASER, now).startswith("the map looks the same from (")


def test_a_turn_is_covered_by_twelve_views_of_58_degrees_and_not_by_three():
    views, _ = turn_of_views(filter_on().field, Pose2D(3.0, 2.0, 0.0))
    assert yaw_covered(views, math.radians(58)) == pytest.approx(math.tau)
    assert yaw_covered(views[:3], math.radians(58)) == pytest.approx(math.radians(58 + 60 + 1), abs=0.02)
    assert latest_turn(views, 0.0, math.radians(58)) == views[1:]  # 11 views 30 degrees apart already cover it
    assert latest_turn(views, 5.0, math.radians(58)) == views[5:]  # not a turn: what there is since t = 5


@pytest.mark.parametrize(("field", "value"), [("accept", 1.5), ("min_seeds", 0), ("range_tolerance", -0.1)])
def test_search_parameters_are_checked(field, value):
    with pytest.raises(ValueError, match=f"global search {field} must be"):
        GlobalSearchParams(**{field: value})
