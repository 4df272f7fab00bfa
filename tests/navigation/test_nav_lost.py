"""A robot that knows it is lost: amcl's confidence, ``localization_lost``, the LOCALIZE state, kidnapping,
the initial-pose and kidnap options, and an unmapped box beside the TurtleBot3 world's pillars."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import navigation
from navigation.cli import main
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.localization import Amcl
from navigation.lost_scenarios import (
    LOST_ROOM_BLOCKS,
    LOST_ROOM_GOALS,
    LOST_ROOM_KIDNAP,
    box_between_pillars,
    lost_room,
    pillars,
    spread_goals,
)
from navigation.maps import OccupancyMap, load_map
from navigation.patrol import LOCALIZE, PatrolMachine
from navigation.planner import Planner
from navigation.relocalize import schedule_kidnap
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation
from navigation.task_library import WaitTask
from navigation.world import MovingObstacle, World, WorldObject

DATA = Path(navigation.__file__).parent / "data"
NOISY = {"odom_linear_noise": 0.05, "odom_angular_noise": 0.05}
GOALS = list(LOST_ROOM_GOALS)


def room(blocks: tuple[tuple[float, float, float, float], ...] = LOST_ROOM_BLOCKS, w: float = 7.0, h: float = 4.0
         ) -> OccupancyMap:
    return lost_room(blocks, w, h)


def amcl_of(sim: Simulation) -> Amcl:
    assert isinstance(sim.localizer, Amcl)
    return sim.localizer


def test_a_tracking_filter_is_confident_and_events_carry_the_believed_and_true_pose():
    sim = Simulation(room(), GOALS[0], SimConfig(localization="amcl", **NOISY))
    machine = PatrolMachine(sim, GOALS, None, max_laps=1)
    summary = run_patrol(machine, handle_sigint=False)
    amcl = amcl_of(sim)
    assert summary.goals_reached == 4 and summary.localization_lost == 0
    assert amcl.confidence.spread < 0.2 and amcl.confidence.score >= 0.9 and not amcl.lost
    loc = sim.events.of_type("localization")
    assert len(loc) >= 4
    for event in loc[1:]:  # the first is written before any step has measured an error
        believed, true = event["believed"], event["true"]
        assert math.hypot(believed["x"] - true["x"], believed["y"] - true["y"]) == pytest.approx(event["error"],
                                                                                                 abs=2e-3)
        assert 0.0 <= event["score"] <= 1.0 and event["lost"] is False
    d = summary.as_dict()
    assert d["localization_lost"] == 0
    believed, true = d["believed_pose"], d["true_pose"]
    assert math.hypot(believed["x"] - true["x"], believed["y"] - true["y"]) < 0.1
    assert LOCALIZE not in machine.entered


@pytest.mark.parametrize("seed", [0, 1])
def test_a_kidnapped_robot_notices_relocalises_and_completes_its_patrol(seed):
    sim = Simulation(room(), GOALS[0], SimConfig(localization="amcl", seed=seed, **NOISY))
    schedule_kidnap(sim, 20.0, LOST_ROOM_KIDNAP)
    machine = PatrolMachine(sim, GOALS, None, max_laps=2)
    summary = run_patrol(machine, handle_sigint=False, max_steps=20_000)
    (kidnap,) = sim.events.of_type("kidnap")
    lost = sim.events.of_type("localization_lost")
    assert lost and 0 < lost[0]["t"] - kidnap["t"] <= 10.0  # noticed within 10 s of simulated time
    assert lost[0]["lost"] is True and "beams on the map" in lost[0]["reason"]
    assert LOCALIZE in machine.entered
    stages = [e["stage"] for e in sim.events.of_type("relocalize")]
    assert stages[-1] == "global"  # neither the old cloud nor a re-seed around the old pose finds it
    (found,) = sim.events.of_type("localization_regained")
    assert math.hypot(found["believed"]["x"] - found["true"]["x"], found["believed"]["y"] - found["true"]["y"]) < 0.3
    assert machine.outcome == "shutdown" and summary.preempt_reason == ""
    assert summary.laps == 2 and summary.goals_reached == 8 and summary.goals_aborted == 0
    assert summary.collisions == 0
    assert summary.localization_lost == 1 and summary.localization_regained == 1
    # The interrupted goal was driven to again: every goal reached within tolerance of the true pose.
    for result in sim.events.of_type("goal_result"):
        if result["status"] == "SUCCEEDED":
            goal = GOALS[int(result["name"].split("_")[1])]
            assert math.hypot(result["robot"]["x"] - goal.x, result["robot"]["y"] - goal.y) < 0.4


def test_localize_gives_up_with_a_reason_where_nothing_can_be_recognised():
    # A 14 m empty hall: from the middle the 6 m laser sees no wall, so no cloud can become confident.
    hall = room((), 14.0, 14.0)
    sim = Simulation(hall, Pose2D(7.0, 7.0, 0.0), SimConfig(localization="amcl"))
    machine = PatrolMachine(sim, [Pose2D(7.5, 7.0, 0.0), Pose2D(6.5, 7.0, 0.0)], None)
    machine.begin()
    sim.run_for(0.5)
    amcl_of(sim).lost = True  # as if the filter had judged itself lost
    sim.events.emit("localization_lost", reason="test")
    summary = run_patrol(machine, handle_sigint=False, max_steps=5000)
    assert LOCALIZE in machine.entered and machine.entered[-1] == "SHUTDOWN"
    assert summary.preempt_reason.startswith("localization lost: no confident pose after scan, local, global")
    assert [e["stage"] for e in sim.events.of_type("relocalize")] == ["scan", "local", "global"]


def test_a_preempt_during_localize_ends_in_shutdown():
    sim = Simulation(room((), 14.0, 14.0), Pose2D(7.0, 7.0, 0.0), SimConfig(localization="amcl"))
    machine = PatrolMachine(sim, [Pose2D(7.5, 7.0, 0.0)], None)
    machine.begin()
    amcl_of(sim).lost = True
    sim.events.emit("localization_lost", reason="test")
    sim.run_for(1.0)
    assert LOCALIZE in machine.active_states()
    machine.request_preempt("test")
    run_patrol(machine, handle_sigint=False, max_steps=100)
    assert machine.entered[-1] == "SHUTDOWN" and sim.teleop is None


def test_a_walker_crossing_the_stopped_robot_leaves_amcl_on_or_localize_recovers_it():
    """The robot waits 12 s at its first goal while a walker crosses just in front of it, twice, then patrols on."""
    body = WorldObject("walker", "cylinder", 2.95, 0.3, radius=0.25, height=1.7)
    walker = World(obstacles=(MovingObstacle(body, (2.95, 0.3), (2.95, 3.7), 0.5),))
    goals = [Pose2D(2.4, 2.0, 0.0), Pose2D(5.5, 2.2, 0.0), Pose2D(2.4, 1.2, math.pi)]
    sim = Simulation(room(), Pose2D(1.0, 1.0, 0.0), SimConfig(localization="amcl", **NOISY), world=walker)
    machine = PatrolMachine(sim, goals, None, max_laps=2, tasks=[[WaitTask(seconds=12)], [], []])
    errors: list[float] = []
    machine.begin()
    while not machine.finished and sim.clock.now < 600:
        sim.step()
        if not amcl_of(sim).lost:
            errors.append(amcl_of(sim).estimate.distance_to(sim.robot.pose))
    assert machine.finished and machine.preempt_reason == ""
    # The walker was in the laser's view while the robot stood at POSE_0 (58 degrees ahead, 6 m).
    waits = [e["t"] for e in sim.events.of_type("state_enter") if e["state"].endswith("POSE_0_WAIT")]
    assert len(waits) == 2
    moving = walker.obstacles[0]
    assert isinstance(moving, MovingObstacle)
    for t0 in waits:  # it crossed the robot's heading, 0.55 m ahead, while the robot stood still
        assert min(abs(moving.position_at(t0 + k * 0.1)[1] - 2.0) for k in range(120)) < 0.05
    # Whenever amcl trusted its pose it was within 0.3 m of the truth (a lost spell is LOCALIZE's to mend).
    assert max(errors) <= 0.3
    assert machine.stats.goals_reached == 6 and machine.stats.goals_aborted == 0
    assert len(sim.events.of_type("localization_regained")) == len(sim.events.of_type("localization_lost"))


@pytest.mark.realdata
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_an_unmapped_box_beside_two_pillars_does_not_drag_amcl(shared_data, seed):
    occ_map = load_map(shared_data / "maps/turtlebot3_world/map.yaml")
    box = box_between_pillars(occ_map)
    gaps = sorted(math.hypot(px - box.x, py - box.y) - 0.25 - 0.15 for px, py in pillars(occ_map))[:2]
    assert all(0.1 < g < 0.2 for g in gaps)  # about 0.15 m from two pillars, as the lesson places it
    world = World(obstacles=(box,))
    field = ObstacleField(occ_map)
    planner = Planner(field)
    goals = [g for g in spread_goals(planner, 44, seed) if not world.collides(g.x, g.y, 0.35)][:40]
    assert len(goals) == 40
    sim = Simulation(occ_map, goals[-1], SimConfig(localization="amcl", seed=seed, **NOISY), field_=field,
                     planner=planner, world=world)
    summary = run_patrol(PatrolMachine(sim, goals, None, max_laps=1), handle_sigint=False)
    assert summary.goals_reached >= 38
    assert summary.collisions == 0
    assert summary.localization_error_max < 0.5 and summary.localization_lost == 0  # no pillar pitch (1.1 m) slid


def test_command_initial_pose_kidnap_and_summary(tmp_path, capsys):
    events = tmp_path / "e.jsonl"
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--time-limit", "30",
                 "--localization", "amcl", "--initial-pose", "14.6", "12.9", "0.05", "--initial-spread", "0.3", "0.1",
                 "--kidnap", "10", "14.0", "12.8", "0", "--events", str(events)])
    out, err = capsys.readouterr()
    assert code == 0, err
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    (kidnap,) = [e for e in lines if e["type"] == "kidnap"]
    assert kidnap["t"] == pytest.approx(10.0, abs=0.11) and kidnap["to"] == {"x": 14.0, "y": 12.8, "yaw": 0.0}
    loc = [e for e in lines if e["type"] == "localization"]
    assert loc and {"believed", "true", "spread", "score", "lost"} <= set(loc[0])
    assert "localization:" in out


@pytest.mark.parametrize(("extra", "message"), [
    (["--initial-pose", "1", "2", "0"], "--initial-pose and --initial-spread need --localization amcl"),
    (["--localization", "amcl", "--kidnap", "5", "-100", "0", "0"], "--kidnap: kidnap pose (-100, 0) is off the map"),
])
def test_command_refuses_lost_robot_options_that_cannot_work(capsys, extra, message):
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--time-limit", "5", *extra])
    assert code == 2
    assert message in capsys.readouterr().err
