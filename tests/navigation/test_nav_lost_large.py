"""Global relocalisation beyond a room: the poses scored follow the free area (within a declared bound), so a
robot kidnapped in the Willow Garage office is found again; and a bare corridor, where every place along the
middle looks the same, ends in a reason that says so rather than a guess."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navigation import amcl_global
from navigation.amcl_global import (
    COARSE_BEAMS,
    COARSE_KEEP,
    GlobalSearchParams,
    along_a_line,
    ambiguity,
    coarse_ring,
    free_area,
    search,
    second_opinion,
    seed_count,
)
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.laser import LaserParams
from navigation.localization import AmclParams, ParticleFilter, compose
from navigation.lost_scenarios import (
    CORRIDOR_GOALS,
    CORRIDOR_KIDNAP,
    CORRIDOR_LENGTH,
    CORRIDOR_WIDTH,
    SYMMETRIC_ROOM_BLOCKS,
    lost_room,
    spread_goals,
)
from navigation.maps import load_map
from navigation.patrol import LOCALIZE, PatrolMachine
from navigation.people_scenarios import corridor_map
from navigation.planner import Planner
from navigation.relocalize import schedule_kidnap
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation
from tests.navigation.test_nav_lost_kidnap import turn_of_views

NOISY = {"odom_linear_noise": 0.05, "odom_angular_noise": 0.05}
LASER = LaserParams(beams=30)
WILLOW = "maps/willow_2010/willow-2010-02-18-0.10.yaml"
KIDNAP_AT = 20.0


def filter_on(occ_map) -> ParticleFilter:  # type: ignore[no-untyped-def]
    return ParticleFilter(ObstacleField(occ_map), AmclParams(), np.random.default_rng(7))


# -- how many poses a search scores --------------------------------------------------------------------------

def test_the_poses_scored_follow_the_free_area_within_the_bounds():
    p = GlobalSearchParams()
    room = filter_on(lost_room())  # 21 m² of free space: the rooms keep the lessons' 20,000 poses
    assert free_area(room) == pytest.approx(21.3, abs=0.1)
    assert seed_count(room, p) == p.min_seeds == 20000
    hall = filter_on(corridor_map(CORRIDOR_LENGTH, CORRIDOR_WIDTH))  # 30 m x 2 m: 50.5 m² at 0.15 m off the walls
    assert seed_count(hall, p) == round(p.seeds_per_square_metre * free_area(hall)) == 45441
    assert seed_count(hall, GlobalSearchParams(max_seeds=30000)) == 30000  # the bound holds
    with pytest.raises(ValueError, match=r"min_seeds \(5000\) must not exceed max_seeds \(4000\)"):
        GlobalSearchParams(min_seeds=5000, max_seeds=4000)


@pytest.mark.realdata
def test_the_willow_office_gets_the_bounded_number_of_poses(shared_data):
    pf = filter_on(load_map(shared_data / WILLOW))
    assert free_area(pf) == pytest.approx(857.2, abs=0.5)  # 771,000 poses wanted at 900 per m²
    assert seed_count(pf, GlobalSearchParams()) == GlobalSearchParams().max_seeds == 600000


@pytest.mark.realdata
def test_a_robot_kidnapped_in_the_willow_office_is_found_again(shared_data):
    """One lap of four goals spread over the office, the robot carried at t = 20 s to the next spread point
    (28.2, 1.7), 30 m away. With 20,000 poses over 857 m² the search found no place that explains the turn (best
    30 % of beams) and the patrol gave up; with poses per square metre it is found within 0.3 m and the lap ends."""
    occ_map = load_map(shared_data / WILLOW)
    field = ObstacleField(occ_map)
    planner = Planner(field)
    points = spread_goals(planner, 5, 1)
    goals, to = points[:4], points[4]
    sim = Simulation(occ_map, goals[-1], SimConfig(localization="amcl", seed=1, **NOISY), field_=field,
                     planner=planner)
    schedule_kidnap(sim, KIDNAP_AT, to)
    machine = PatrolMachine(sim, goals, None, max_laps=1)
    run_patrol(machine, handle_sigint=False, max_steps=30_000)
    lost = sim.events.of_type("localization_lost")
    assert lost and 0 < lost[0]["t"] - KIDNAP_AT <= 10.0
    found = sim.events.of_type("localization_regained")
    assert found and all(math.hypot(e["believed"]["x"] - e["true"]["x"], e["believed"]["y"] - e["true"]["y"]) < 0.3
                         for e in found)
    assert machine.end_reason == "" and machine.stats.goals_reached == 4


# -- a large map's search: a thinned ring first ---------------------------------------------------------------

def test_the_thinned_ring_keeps_every_other_view_while_they_cover_the_turn_and_a_third_of_the_beams():
    field = ObstacleField(lost_room())
    views, _ = turn_of_views(field, Pose2D(2.0, 2.0, 0.0))  # 12 views 30 degrees apart, 58 degrees wide
    ring = coarse_ring(views, LASER)
    assert [v.t for v in ring] == [float(k) for k in range(0, 12, 2)]  # 6 x 58 = 348 of 360 degrees
    assert all(len(v.scan.ranges) == COARSE_BEAMS for v in ring)  # every 3rd of 30
    assert np.allclose(ring[1].scan.angles(), views[2].scan.angles()[::3], rtol=0, atol=1e-12)
    assert np.array_equal(ring[1].scan.ranges, views[2].scan.ranges[::3], equal_nan=True)
    four, _ = turn_of_views(field, Pose2D(2.0, 2.0, 0.0), n=4)  # 90 degrees apart: every other would leave gaps
    assert [v.t for v in coarse_ring(four, LASER)] == [0.0, 1.0, 2.0, 3.0]


@pytest.mark.realdata
def test_a_large_search_scores_most_poses_on_the_thinned_ring_and_finds_the_same_place(shared_data, monkeypatch):
    """600,000 poses over the Willow Garage office: each is scored on 6 views of 10 beams, the best 20,000 on the
    whole ring (12 x 30), about a sixth of the beam evaluations of one pass on the whole ring, and the place found
    is the one the whole ring finds."""
    pf = filter_on(load_map(shared_data / WILLOW))
    truth = Pose2D(28.2, 1.7, 0.3)
    views, odom_now = turn_of_views(pf.field, truth)
    beams_scored = [0]
    score = pf.beam_log_likelihoods

    def counted(scan, x, y, yaw):  # type: ignore[no-untyped-def]
        out = score(scan, x, y, yaw)
        beams_scored[0] += out.size
        return out

    monkeypatch.setattr(pf, "beam_log_likelihoods", counted)
    thinned_first = search(pf, views, odom_now, LASER)
    with_thinning = beams_scored[0]
    monkeypatch.setattr(amcl_global, "COARSE_KEEP", 10**9)  # one pass on the whole ring
    beams_scored[0] = 0
    whole = search(pf, views, odom_now, LASER)
    assert with_thinning < 0.25 * beams_scored[0]
    assert with_thinning > 600000 * 6 * COARSE_BEAMS  # the first pass, then COARSE_KEEP on the whole ring
    assert COARSE_KEEP == 20000
    now = compose(truth, odom_now)
    for best in (thinned_first[0], whole[0]):
        assert math.hypot(best.pose.x - now.x, best.pose.y - now.y) < 0.1 and best.agreement > 0.85


# -- a corridor that looks the same all along ----------------------------------------------------------------

def test_in_a_bare_corridor_the_search_says_it_cannot_tell_where_along_it():
    pf = filter_on(corridor_map(CORRIDOR_LENGTH, CORRIDOR_WIDTH))
    truth = Pose2D(15.0, 1.0, 1.2)
    views, odom = turn_of_views(pf.field, truth)
    now = compose(truth, odom)
    found = search(pf, views, odom, LASER)
    assert ambiguity(found, GlobalSearchParams()) is not None
    reason = along_a_line(found, GlobalSearchParams())
    assert reason.startswith("cannot tell where along the corridor: the ")
    count = int(reason.split(": the ")[1].split(" best places")[0])
    equal = [h for h in found if h.agreement >= found[0].agreement - GlobalSearchParams().ambiguity_margin]
    assert count == len(equal) >= 3
    # The places named span metres of the stretch whose ends the laser (6 m) cannot see, the robot among them.
    ends = [float(v) for v in reason.split("from (")[1].split(")")[0].split(",")]
    ends += [float(v) for v in reason.split(" to (")[1].split(")")[0].split(",")]
    assert ends[0] < now.x < ends[2] and ends[2] - ends[0] > 5.0 and all(abs(y - 1.0) < 0.1 for y in ends[1::2])
    assert second_opinion(pf, views, odom, LASER, now).startswith("cannot tell where along the corridor")


def test_two_places_alike_are_not_a_corridor():
    """A symmetric room's two twins are on a line too (any two places are): they are named as two places."""
    pf = filter_on(lost_room(SYMMETRIC_ROOM_BLOCKS))
    views, odom = turn_of_views(pf.field, Pose2D(2.2, 3.2, 0.5))
    found = search(pf, views, odom, LASER)
    assert ambiguity(found, GlobalSearchParams()) is not None
    assert along_a_line(found, GlobalSearchParams()) == ""


def test_a_robot_kidnapped_into_a_bare_corridor_gives_up_saying_where_the_doubt_lies():
    """Carried to the middle of a 30 m bare corridor (15 m from either end, beyond the laser's 6 m): lost within
    10 s, no pose trusted, no goal reached after the kidnap, and the reason names the corridor."""
    sim = Simulation(corridor_map(CORRIDOR_LENGTH, CORRIDOR_WIDTH), CORRIDOR_GOALS[0],
                     SimConfig(localization="amcl", seed=3, **NOISY))
    schedule_kidnap(sim, KIDNAP_AT, CORRIDOR_KIDNAP)
    machine = PatrolMachine(sim, list(CORRIDOR_GOALS), None, max_laps=2)
    run_patrol(machine, handle_sigint=False, max_steps=20_000)
    lost = sim.events.of_type("localization_lost")
    assert lost and 0 < lost[0]["t"] - KIDNAP_AT <= 10.0
    assert machine.entered[-2:] == [LOCALIZE, "SHUTDOWN"]
    assert machine.end_reason.startswith("localization lost: no confident pose after scan, local, global (cannot "
                                         "tell where along the corridor: the ")
    assert not sim.events.of_type("localization_regained")
    kidnap = sim.events.of_type("kidnap")[0]
    assert not [r for r in sim.events.of_type("goal_result") if r["t"] > kidnap["t"] and r["status"] == "SUCCEEDED"]
    assert sim.collisions == 0
