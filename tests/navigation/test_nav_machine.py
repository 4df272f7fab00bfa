"""Every path through the patrol state machine, each checked by the exact sequence of states entered."""

from __future__ import annotations

import math
import os
import signal

import numpy as np
import pytest

from navigation.docking import DockingStation
from navigation.geometry import Pose2D
from navigation.laptop_monitor import laptop_battery_monitor
from navigation.maps import OCCUPIED, OccupancyMap
from navigation.patrol import PatrolMachine, patrol_transitions
from navigation.runner import run_patrol

MP = "MONITORED_PATROL"
MP_ENTRY = [MP, f"{MP}.PATROL", f"{MP}.ROBOT_BATTERY_MONITOR"]
#: The entry with the laptop's monitor that objrec-patrol adds (navigation.laptop_monitor).
MP_LAPTOP_ENTRY = [*MP_ENTRY, f"{MP}.LAPTOP_BATTERY_MONITOR"]
DOCKING = ["DOCK_AT_STATION", "DOCK_AT_STATION.MOVE_TO_STATION", "DOCK_AT_STATION.DOCK"]


def pose(i: int) -> str:
    return f"{MP}.PATROL.POSE_{i}"


def results(machine: PatrolMachine) -> list[tuple[str, str]]:
    return [(e["name"], e["status"]) for e in machine.sim.events.of_type("goal_result")]


def patrol_prefix(entered: list[str], n_goals: int, entry: list[str] = MP_ENTRY) -> int:
    """Check the patrol part (MP entry then POSE_0, POSE_1, ... cyclically); return where it ends."""
    first = len(entry)
    assert entered[:first] == entry
    k = first
    while k < len(entered) and entered[k].startswith(f"{MP}.PATROL.POSE_"):
        assert entered[k] == pose((k - first) % n_goals)
        k += 1
    return k


def laptop_watched(machine: PatrolMachine) -> PatrolMachine:
    """The same patrol (same simulation, goals, station, laps) with the laptop's monitor, as objrec-patrol
    builds it."""
    return PatrolMachine(machine.sim, machine.goals, machine.station_pose, max_laps=machine.max_laps,
                         resume_after_charging=machine.resume, monitors=[laptop_battery_monitor()])


@pytest.fixture
def goals(b5203_poses) -> list[Pose2D]:
    return list(b5203_poses.goals[:3])


def test_normal_lap_visits_every_goal_then_shuts_down(make_patrol, goals):
    machine = make_patrol(goals, max_laps=1)
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, pose(0), pose(1), pose(2), "SHUTDOWN"]
    assert machine.outcome == "shutdown"
    assert summary.final_states == ("SHUTDOWN",)
    assert (summary.laps, summary.goals_reached, summary.goals_aborted) == (1, 3, 0)
    assert summary.collisions == 0
    assert results(machine) == [("POSE_0", "SUCCEEDED"), ("POSE_1", "SUCCEEDED"), ("POSE_2", "SUCCEEDED")]
    end = machine.sim.robot.pose
    assert end.distance_to(goals[2]) <= 0.15
    assert abs(math.remainder(end.yaw - goals[2].yaw, 2 * math.pi)) <= 0.3
    assert machine.sim.robot.v == 0.0 and machine.sim.robot.w == 0.0
    # Leaving MONITORED_PATROL left both regions.
    exits = [e["state"] for e in machine.sim.events.of_type("state_exit")]
    assert exits[-4:] == [pose(2), f"{MP}.PATROL", f"{MP}.ROBOT_BATTERY_MONITOR", MP]


def test_two_laps_wrap_round_to_pose_0(make_patrol, goals):
    machine = make_patrol(goals[:2], max_laps=2)
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, pose(0), pose(1), pose(0), pose(1), "SHUTDOWN"]
    assert machine.stats.laps == 2


def test_unreachable_goals_are_aborted_and_skipped(make_patrol, b5203_map, goals):
    data = b5203_map.data.copy()
    res = b5203_map.resolution
    data[round(12.6 / res):round(13.8 / res), round(9.5 / res):round(9.95 / res)] = OCCUPIED  # close the door
    closed = OccupancyMap(data, res, b5203_map.origin)
    in_table = Pose2D(12.7, 12.2, 0.0)      # inside the central table
    in_corridor = Pose2D(8.6, 13.0, 0.0)    # free, but behind the closed door
    machine = make_patrol([goals[0], in_table, in_corridor, goals[2]], occ_map=closed, max_laps=1)
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, pose(0), pose(1), pose(2), pose(3), "SHUTDOWN"]
    assert results(machine) == [("POSE_0", "SUCCEEDED"), ("POSE_1", "ABORTED"), ("POSE_2", "ABORTED"),
                                ("POSE_3", "SUCCEEDED")]
    texts = [e["text"] for e in machine.sim.events.of_type("goal_result")]
    assert texts[1] == "goal is in an obstacle"
    assert texts[2].startswith("no path") and "after 2 recovery attempts" in texts[2]
    recoveries = machine.sim.events.of_type("recovery")
    assert [r["attempt"] for r in recoveries] == [1, 2]
    assert (summary.laps, summary.goals_reached, summary.goals_aborted, summary.collisions) == (1, 2, 2, 0)


def test_robot_battery_low_docks_and_charges(make_patrol, goals):
    machine = make_patrol(goals, robot_battery_percent=28.4)
    summary = run_patrol(machine, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals))
    assert k > len(MP_ENTRY), "the patrol should have started before the battery ran low"
    assert machine.entered[k:] == [*DOCKING, "WAIT_UNTIL_CHARGED", "SHUTDOWN"]
    battery = machine.sim.robot_battery
    assert battery.percentage == pytest.approx(100.0)
    kinds = [e["event"] for e in machine.sim.events.of_type("robot_battery")]
    assert kinds == ["BATTERY_LOW", "PLUGGED_TO_DOCKBASE", "CHARGE_COMPLETED"]
    low_t = machine.sim.events.of_type("robot_battery")[0]["t"]
    done_t = machine.sim.events.of_type("robot_battery")[2]["t"]
    # From 28 % to full at 2200 mAh / 1.5 h: 72 % of 90 minutes, plus the drive to the dock.
    assert 0.72 * 5400 < done_t - low_t < 0.72 * 5400 + 120
    # The goal running when the battery ran low was preempted by leaving MONITORED_PATROL.
    assert results(machine)[-2][1] == "PREEMPTED"
    assert results(machine)[-1] == ("MOVE_TO_STATION", "SUCCEEDED")
    dock = machine.sim.station.docked_pose(0.18)
    assert machine.sim.robot.pose.distance_to(dock) < 0.05
    assert summary.goals_preempted == 1
    assert summary.collisions == 0 and machine.outcome == "shutdown"


def test_robot_battery_low_without_station_shuts_down(make_patrol, goals):
    machine = make_patrol(goals, station=None, robot_battery_percent=28.4)
    run_patrol(machine, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals))
    assert machine.entered[k:] == ["SHUTDOWN"]
    assert machine.sim.events.of_type("robot_battery")[0]["event"] == "BATTERY_LOW"
    assert machine.sim.robot.v == 0.0


def test_robot_battery_already_low_at_start(make_patrol, goals):
    """BATTERY_LOW fires on crossing only; the monitor also looks at the level when it starts."""
    machine = make_patrol(goals, station=None, robot_battery_percent=20.0)
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, pose(0), "SHUTDOWN"]


def test_docking_fails_when_the_dock_is_not_ahead(make_patrol, goals):
    behind = DockingStation(Pose2D(13.4 - 0.01, 12.8 + 1.5, 0.0))  # not in front of the station pose
    machine = make_patrol(goals, dock=behind, robot_battery_percent=28.4)
    run_patrol(machine, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals))
    assert machine.entered[k:] == [*DOCKING, "SHUTDOWN"]
    action = machine.sim.events.of_type("action_result")
    assert action[0]["status"] == "ABORTED" and action[0]["text"].startswith("no dock signal")
    assert not machine.sim.robot_battery.charging


def test_docking_fails_when_the_station_cannot_be_reached(make_patrol, goals):
    in_table = Pose2D(12.7, 12.2, 0.0)
    machine = make_patrol(goals, station=in_table, robot_battery_percent=28.4)
    run_patrol(machine, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals))
    assert machine.entered[k:] == ["DOCK_AT_STATION", "DOCK_AT_STATION.MOVE_TO_STATION", "SHUTDOWN"]
    assert results(machine)[-1] == ("MOVE_TO_STATION", "ABORTED")


def test_laptop_battery_low_shuts_down(make_patrol, goals):
    machine = laptop_watched(make_patrol(goals, laptop_battery_percent=20.3))
    summary = run_patrol(machine, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals), MP_LAPTOP_ENTRY)
    assert k > len(MP_LAPTOP_ENTRY)
    assert machine.entered[k:] == ["SHUTDOWN"]
    assert summary.preempt_reason == "laptop battery low (19.9 %, not charging)"
    # 0.3 % at 2.5 h per 100 % is 27 s; the monitor polls once a second.
    low = machine.sim.events.of_type("laptop_battery")
    assert len(low) == 1 and low[0]["t"] == pytest.approx(27.0, abs=0.15)
    assert machine.sim.laptop_battery.percentage < 20.0
    assert 27.0 <= summary.sim_time <= 28.2
    assert results(machine)[-1][1] == "PREEMPTED"


def test_laptop_on_mains_never_runs_low(make_patrol, goals):
    machine = laptop_watched(make_patrol(goals, laptop_battery_percent=5.0, laptop_plugged=True, max_laps=1))
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_LAPTOP_ENTRY, pose(0), pose(1), pose(2), "SHUTDOWN"]


def test_without_the_laptop_monitor_a_low_laptop_ends_nothing(make_patrol, goals):
    """The machine alone does not know the laptop: a program that does not add the monitor patrols on."""
    machine = make_patrol(goals, laptop_battery_percent=20.05, max_laps=1)  # below 20 % after 4.5 s
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, pose(0), pose(1), pose(2), "SHUTDOWN"]
    assert summary.preempt_reason == "" and machine.sim.laptop_battery.percentage < 20.0


def test_the_stopped_laptop_monitor_is_no_result(make_patrol, goals):
    """Docking leaves MONITORED_PATROL: the monitor stops there (task_stop) and starts again in each state it
    watches in; it never ends as a preempted task."""
    machine = laptop_watched(make_patrol(goals, robot_battery_percent=28.4))
    run_patrol(machine, handle_sigint=False, time_limit=120.0)
    region = f"{MP}.LAPTOP_BATTERY_MONITOR"
    assert [e["status"] for e in machine.sim.events.of_type("task_result") if e["state"] == region] == []
    stops = [e["text"] for e in machine.sim.events.of_type("task_stop") if e["state"] == region]
    starts = [e for e in machine.sim.events.of_type("task_start") if e["state"] == region]
    assert len(starts) == len(stops) >= 3 and set(stops) == {"state left"}  # MP, DOCK_AT_STATION, WAIT...


def test_sigint_preempts_the_patrol_cleanly(make_patrol, goals):
    machine = make_patrol(goals)
    machine.sim.clock.call_at(15.0, lambda: os.kill(os.getpid(), signal.SIGINT))
    previous = signal.getsignal(signal.SIGINT)
    summary = run_patrol(machine, handle_sigint=True)
    assert signal.getsignal(signal.SIGINT) is previous
    k = patrol_prefix(machine.entered, len(goals))
    assert machine.entered[k:] == ["SHUTDOWN"]
    assert summary.preempt_reason == "SIGINT" and machine.outcome == "shutdown"
    assert results(machine)[-1][1] == "PREEMPTED"
    assert summary.goals_preempted == 1
    assert 15.0 <= summary.sim_time <= 15.3
    assert machine.sim.robot.v == 0.0 and machine.sim.robot.w == 0.0


def test_sigint_while_charging_ends_the_wait(make_patrol, goals):
    machine = make_patrol(goals, robot_battery_percent=28.4)

    def interrupt_when_waiting(m: PatrolMachine) -> None:
        if m.entering == "WAIT_UNTIL_CHARGED":
            m.sim.clock.call_later(60.0, lambda: os.kill(os.getpid(), signal.SIGINT))

    machine.state_listeners.append(interrupt_when_waiting)
    summary = run_patrol(machine, handle_sigint=True)
    k = patrol_prefix(machine.entered, len(goals))
    assert machine.entered[k:] == [*DOCKING, "WAIT_UNTIL_CHARGED", "SHUTDOWN"]
    assert summary.preempt_reason == "SIGINT"
    assert machine.sim.robot_battery.percentage < 35.0  # it did not wait for a full battery


def test_time_limit_preempts_like_sigint(make_patrol, goals):
    machine = make_patrol(goals)
    summary = run_patrol(machine, time_limit=40.0, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals))
    assert k >= 6
    assert machine.entered[k:] == ["SHUTDOWN"]
    assert summary.preempt_reason == "time limit"
    assert summary.sim_time == pytest.approx(40.1, abs=0.05)


def test_resume_after_charging_continues_the_interrupted_goal(make_patrol, b5203_poses):
    goals = list(b5203_poses.goals[:4])
    machine = make_patrol(goals, robot_battery_percent=28.2, resume=True, max_laps=1)
    summary = run_patrol(machine, handle_sigint=False)
    k = patrol_prefix(machine.entered, len(goals))
    interrupted = machine.entered[k - 1]
    index = int(interrupted.rsplit("_", 1)[1])
    tail = machine.entered[k:]
    assert tail[:6] == [*DOCKING, "WAIT_UNTIL_CHARGED", "UNDOCK", MP]
    regions = 6 + len(MP_ENTRY) - 1
    assert tail[6:regions] == MP_ENTRY[1:]
    assert tail[regions:] == [pose(i) for i in range(index, len(goals))] + ["SHUTDOWN"]
    assert summary.laps == 1 and summary.collisions == 0
    assert summary.goals_reached == len(goals)  # the interrupted goal was driven to after all
    kinds = [e["event"] for e in machine.sim.events.of_type("robot_battery")]
    assert kinds == ["BATTERY_LOW", "PLUGGED_TO_DOCKBASE", "CHARGE_COMPLETED", "UNPLUGGED"]


def test_transitions_are_data_and_cover_every_outcome():
    table = patrol_transitions(2, monitors=[laptop_battery_monitor()])
    triggers = {(t["trigger"], t["source"]) for t in table}
    assert ("robot_battery_low", f"{MP}.ROBOT_BATTERY_MONITOR") in triggers
    assert ("laptop_battery_low", f"{MP}.LAPTOP_BATTERY_MONITOR") in triggers
    assert ("preempted", f"{MP}.PATROL") in triggers
    assert {t["dest"] for t in table} >= {"DOCK_AT_STATION", "WAIT_UNTIL_CHARGED", "SHUTDOWN", "UNDOCK"}
    assert all(isinstance(t["trigger"], str) for t in table)


def test_machine_needs_goals(make_patrol):
    with pytest.raises(ValueError, match="at least one goal"):
        make_patrol([])


def test_single_goal_patrol(make_patrol, goals):
    machine = make_patrol(goals[:1], max_laps=2)
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, pose(0), pose(0), "SHUTDOWN"]
    assert np.isclose(machine.stats.goals_reached, 2)


def test_second_sigint_gives_up_at_once():
    from strictio.signals import StopSignals

    previous = signal.getsignal(signal.SIGINT)
    with StopSignals() as flag:
        os.kill(os.getpid(), signal.SIGINT)
        assert flag.count == 1
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is previous


@pytest.mark.parametrize("plugged", [False, True])
def test_objrec_patrol_adds_the_laptop_monitor_unless_plugged(tmp_path, capsys, plugged):
    """The command watches the laptop (its region drawn, its reason in the summary); --laptop-plugged: no monitor."""
    from navigation.cli import main
    from tests.navigation.conftest import DATA

    diagram = tmp_path / "machine.md"
    argv = [str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--laptop-battery", "20.3",
            "--time-limit", "40", "--diagram", str(diagram), "--events", str(tmp_path / "events.jsonl")]
    assert main(argv + (["--laptop-plugged"] if plugged else [])) == 0
    out, text = capsys.readouterr().out, diagram.read_text()
    if plugged:
        assert "outcome:        shutdown (time limit)" in out
        assert "LAPTOP" not in text and "LAPTOP" not in (tmp_path / "events.jsonl").read_text()
    else:
        assert "outcome:        shutdown (laptop battery low (19.9 %, not charging))" in out
        assert "MONITORED_PATROL --> SHUTDOWN : laptop_battery_low from LAPTOP_BATTERY_MONITOR" in text
        assert "WAIT_UNTIL_CHARGED --> SHUTDOWN : robot_battery_empty, laptop_battery_low, charged, preempted" in text
