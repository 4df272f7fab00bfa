"""move_base's ``wait`` recovery (Nav2's Wait): a person standing in a corridor too narrow to pass is waited for,
facing the way, and the robot drives on as soon as they have gone; a person who stays still ends in the
same honest abort as before, within the no-progress bound. Simulated time only."""

from __future__ import annotations

import dataclasses
import math

import pytest

from navigation.geometry import Pose2D
from navigation.move_base import (
    KNOWN_RECOVERY_BEHAVIOURS,
    PATIENT_RECOVERY_BEHAVIOURS,
    RECOVERY_BEHAVIOURS,
    GoalStatus,
    MoveBaseParams,
)
from navigation.people_scenarios import WALKER_RADIUS, corridor_map
from navigation.simulation import SimConfig, Simulation
from navigation.world import World, WorldObject

GOAL = Pose2D(8.0, 0.6, 0.0)
LEAVES = 16.0  # the person walks off 16 s into the run: after the default behaviours, within the wait
NO_WAY = "no path round the obstacles the map does not show"


def person_in_a_narrow_corridor(order: tuple[str, ...], leaves_at: float | None, patience: float = 15.0
                                ) -> tuple[Simulation, GoalStatus, str]:
    """A 1.2 m corridor with a person standing in its middle at x = 5 (0.35 m each side: the robot needs 0.56 m);
    the person walks off (is taken out of the world) at ``leaves_at``. The robot drives from x = 1 to x = 8."""
    person = WorldObject("person", "cylinder", 5.0, 0.6, radius=WALKER_RADIUS, height=1.7)
    config = SimConfig(move_base=MoveBaseParams(recovery_behaviours=order, patience=patience))
    sim = Simulation(corridor_map(10.0, 1.2), Pose2D(1.0, 0.6, 0.0), config, world=World(obstacles=(person,)))
    got: list[tuple[GoalStatus, str]] = []
    sim.move_base.send_goal(GOAL, lambda status, text: got.append((status, text)))
    while not got and sim.clock.now < 300.0:
        if leaves_at is not None and sim.world.obstacles and sim.clock.now >= leaves_at - 1e-9:
            sim.world = dataclasses.replace(sim.world, obstacles=())
        sim.step()
    assert got, "the goal got no result"
    return sim, *got[0]


def behaviours(sim: Simulation) -> list[str]:
    return [e["behaviour"] for e in sim.events.of_type("recovery")]


def test_without_waiting_the_robot_gives_up_before_the_person_moves_on():
    sim, status, text = person_in_a_narrow_corridor(RECOVERY_BEHAVIOURS, leaves_at=LEAVES)
    assert (status, text) == (GoalStatus.ABORTED, f"{NO_WAY} (after 3 recovery attempts)")
    assert behaviours(sim) == ["clear_costmap", "rotate", "back_up"] and sim.clock.now < LEAVES
    assert sim.collisions == 0


def test_a_patient_robot_waits_and_drives_on_once_the_person_has_gone():
    sim, status, text = person_in_a_narrow_corridor(PATIENT_RECOVERY_BEHAVIOURS, leaves_at=LEAVES)
    assert (status, text) == (GoalStatus.SUCCEEDED, "goal reached")
    assert behaviours(sim) == ["clear_costmap", "wait"]  # no turn, no back-up: the wait was enough
    (wait,) = [e for e in sim.events.of_type("recovery") if e["behaviour"] == "wait"]
    assert wait["reason"] == NO_WAY and wait["patience"] == 15.0 and wait["t"] < LEAVES
    # It planned again within one fast scan period (3 s / 4) of the person leaving, and drove through.
    replans = [e for e in sim.events.of_type("plan") if e["t"] >= LEAVES and e["ok"]]
    assert replans and replans[0]["t"] - LEAVES <= 0.75 + 0.1
    assert math.hypot(sim.robot.x - GOAL.x, sim.robot.y - GOAL.y) < 0.3 and sim.collisions == 0


def test_a_person_who_stays_is_waited_for_only_as_long_as_the_patience_then_the_abort_has_its_reason():
    sim, status, text = person_in_a_narrow_corridor(PATIENT_RECOVERY_BEHAVIOURS, leaves_at=None)
    assert (status, text) == (GoalStatus.ABORTED, f"{NO_WAY} (after 4 recovery attempts)")
    assert behaviours(sim) == ["clear_costmap", "wait", "rotate", "back_up"]
    starts = {e["behaviour"]: e["t"] for e in sim.events.of_type("recovery")}
    assert starts["rotate"] - starts["wait"] == pytest.approx(15.0, abs=0.15)
    params = MoveBaseParams(recovery_behaviours=PATIENT_RECOVERY_BEHAVIOURS)
    assert sim.clock.now <= params.no_progress_bound(SimConfig().dt) and sim.collisions == 0


def test_wait_is_known_optional_and_counted_in_the_no_progress_bound():
    assert set(KNOWN_RECOVERY_BEHAVIOURS) == {*RECOVERY_BEHAVIOURS, "wait"} == set(PATIENT_RECOVERY_BEHAVIOURS)
    patient = MoveBaseParams(recovery_behaviours=PATIENT_RECOVERY_BEHAVIOURS, patience=15.0)
    plain = MoveBaseParams()
    assert patient.no_progress_bound(0.1) == pytest.approx(plain.no_progress_bound(0.1) + 10.1 + 15.1)
    with pytest.raises(ValueError, match="patience must be zero or positive seconds, got -1"):
        MoveBaseParams(patience=-1.0)


def test_an_empty_costmap_or_no_patience_skips_the_wait():
    sim, status, text = person_in_a_narrow_corridor(PATIENT_RECOVERY_BEHAVIOURS, leaves_at=None, patience=0.0)
    assert (status, text) == (GoalStatus.ABORTED, f"{NO_WAY} (after 3 recovery attempts)")
    assert behaviours(sim) == ["clear_costmap", "rotate", "back_up"]
