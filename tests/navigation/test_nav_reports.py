"""Monitors in every state: a laptop that dies while the robot charges on its dock ends the run with
that reason, and an empty robot battery is named as such, not as a goal that made no progress."""

from __future__ import annotations

from dataclasses import replace

import cv2
import pytest

from navigation.battery import LaptopBatteryParams, RobotBatteryParams
from navigation.laptop_monitor import laptop_battery_monitor
from navigation.patrol import OUTSIDE_STATES, PatrolMachine, patrol_transitions
from navigation.render import (
    BELIEVED_COLOUR,
    KIDNAP_COLOUR,
    LOST_COLOUR,
    LocalizationMarks,
    RunPicture,
    render_still,
    save_render,
)
from navigation.runner import run_patrol


@pytest.fixture
def goals(b5203_poses):
    return list(b5203_poses.goals[:3])


def test_a_dead_laptop_on_the_dock_ends_the_run_with_that_reason(make_patrol, goals):
    """The robot battery runs low, the robot docks and charges (1.5 h); the laptop, 30 % on a 0.5 h runtime
    and not plugged in, drops below 20 % three minutes in, while the robot waits on the dock."""
    plain = make_patrol(goals, robot_battery_percent=28.4, laptop_battery_percent=30.0,
                        laptop_battery=replace(LaptopBatteryParams(), runtime_h=0.5))
    # with the laptop's monitor, as objrec-patrol adds it
    machine = PatrolMachine(plain.sim, plain.goals, plain.station_pose, monitors=[laptop_battery_monitor()])
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered[-2:] == ["WAIT_UNTIL_CHARGED", "SHUTDOWN"], machine.entered
    assert summary.outcome == "shutdown" and summary.preempt_reason == "laptop battery low (19.9 %, not charging)"
    low = machine.sim.events.of_type("laptop_battery")
    docked_at = next(e["t"] for e in machine.sim.events.of_type("state_enter") if e["state"] == "WAIT_UNTIL_CHARGED")
    # 10 % of a 0.5 h runtime is 180 s; the watch polls once a simulated second.
    assert len(low) == 1 and low[0]["t"] > docked_at and low[0]["t"] == pytest.approx(180.0, abs=0.15)
    assert summary.sim_time <= low[0]["t"] + 1.1
    assert machine.sim.robot_battery.charging  # it was charging all the while: only the laptop ended the run


def test_an_empty_robot_battery_is_named(make_patrol, goals, b5203_poses):
    """Low at the start, away from the dock, with a battery that empties in 5 s of driving (18 s from full): the
    run ends on the way to the station with "robot battery empty", not with a goal aborted for want of progress."""
    machine = make_patrol(goals, start=goals[2], robot_battery_percent=25.0,
                          robot_battery=replace(RobotBatteryParams(), runtime_h=0.005))
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered[-1] == "SHUTDOWN"
    assert summary.preempt_reason == "robot battery empty"
    empty = [e for e in machine.sim.events.of_type("robot_battery") if e["event"] == "EMPTY"]
    assert len(empty) == 1 and empty[0]["state"].startswith("DOCK_AT_STATION")
    aborted = [e for e in machine.sim.events.of_type("goal_result") if "no progress" in str(e.get("text", ""))]
    assert aborted == []


def test_monitor_outcomes_lead_out_of_every_state():
    table = patrol_transitions(2, monitors=[laptop_battery_monitor()])
    laptop = {t["source"] for t in table if t["trigger"] == "laptop_battery_low"}
    empty = {t["source"] for t in table if t["trigger"] == "robot_battery_empty"}
    assert set(OUTSIDE_STATES) <= laptop and set(OUTSIDE_STATES) <= empty
    assert {t["dest"] for t in table if t["trigger"] in ("laptop_battery_low", "robot_battery_empty")} == {"SHUTDOWN"}


# -- pictures ---------------------------------------------------------------------------------------------
def test_the_animation_is_large_enough_to_project(b5203_map, b5203_poses, tmp_path):
    trajectory = [(0.1 * k, 12.0 + 0.01 * k, 13.0, 0.0) for k in range(200)]
    out = save_render(tmp_path / "run.gif", RunPicture(b5203_map, trajectory, list(b5203_poses.goals)))
    ok, anim = cv2.imreadanimation(str(out))
    assert ok and len(anim.frames) == 100
    assert max(anim.frames[0].shape[:2]) == 800  # was 326 on the long side


def test_the_believed_pose_losses_and_kidnaps_are_drawn(b5203_map, b5203_poses):
    marks = LocalizationMarks()
    pose = {"x": 12.0, "y": 13.0, "yaw": 0.0}
    for t, x in [(0.0, 12.0), (10.0, 13.0), (20.0, 14.0)]:
        marks({"t": t, "type": "localization", "believed": {**pose, "x": x}, "true": pose})
    marks({"t": 25.0, "type": "localization_lost", "believed": {**pose, "x": 15.0}, "true": {**pose, "y": 12.0},
           "reason": "r"})
    marks({"t": 30.0, "type": "kidnap", "from": pose, "to": {**pose, "y": 11.0}})
    marks({"t": 31.0, "type": "goal_result"})  # other events are left alone
    assert len(marks.believed) == 4 and len(marks.lost) == 1 and len(marks.kidnaps) == 1
    trajectory = [(0.0, 12.0, 13.0, 0.0), (30.0, 12.0, 13.0, 0.0)]
    plain = render_still(RunPicture(b5203_map, trajectory, list(b5203_poses.goals)))
    drawn = render_still(RunPicture(b5203_map, trajectory, list(b5203_poses.goals), localization=marks))
    for colour in (BELIEVED_COLOUR, LOST_COLOUR, KIDNAP_COLOUR):
        assert (drawn == colour).all(axis=2).sum() > (plain == colour).all(axis=2).sum() + 10, colour
