"""The patrol drives a robot through navigation.robot_interface.PatrolRobot only: the simulator keeps that
protocol, the machine and its runner run unchanged on a robot that offers nothing else, and robots are plug-ins
named by --robot."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import navigation
from navigation.cli import main
from navigation.geometry import Pose2D
from navigation.patrol import PatrolMachine
from navigation.robot_interface import (
    BatteryView,
    GoalClient,
    PatrolClock,
    PatrolRobot,
    RobotAction,
    RobotBatteryView,
    RobotReport,
    machine_trace,
)
from navigation.robots import ROBOTS, RobotError, SimulatedRobot, open_robot, parse_robot_spec
from navigation.runner import run_patrol
from navigation.simulation import Simulation

DATA = Path(navigation.__file__).parent / "data"
STATION = Pose2D(14.4, 12.8, 0.0)  # the station pose the make_patrol fixture uses
POSES = str(DATA / "b5203.txt")
MAP = str(DATA / "b5203.yaml")
IN_TABLE = Pose2D(12.7, 12.2, 0.0)  # inside the central table of B5.2.03: aborted at once

# What each protocol offers; the proxies below let through exactly these names.
ROBOT_NAMES = ("clock", "events", "move_base", "robot_battery", "laptop_battery", "dock_action", "undock_action",
               "wall_clock", "start_dock", "start_undock", "pose_estimate", "halt", "step", "report", "close")
CLOCK_NAMES = ("now", "call_later", "every")
GOAL_CLIENT_NAMES = ("active", "goal", "send_goal", "cancel_goal")
ACTION_NAMES = ("active", "cancel")
BATTERY_NAMES = ("percentage", "is_low", "is_full")


class Only:
    """A view of ``target`` that has only ``names`` (each optionally wrapped): using anything else fails."""

    def __init__(self, target: Any, names: tuple[str, ...], wrap: dict[str, Any] | None = None) -> None:
        object.__setattr__(self, "_target", target)
        object.__setattr__(self, "_names", names)
        object.__setattr__(self, "_wrap", wrap or {})

    def __getattr__(self, name: str) -> Any:
        if name not in self._names:
            raise AttributeError(f"the patrol used {name!r}, which is not part of the robot protocol")
        value = getattr(self._target, name)
        wrap = self._wrap.get(name)
        return wrap(value) if wrap is not None and value is not None else value

    def __setattr__(self, name: str, value: Any) -> None:
        if name not in self._names:
            raise AttributeError(f"the patrol set {name!r}, which is not part of the robot protocol")
        setattr(self._target, name, value)


def protocol_only(sim: Simulation) -> Any:
    """The simulator as a robot that offers the protocol and nothing more, down to its parts."""
    return Only(sim, ROBOT_NAMES, {
        "clock": lambda c: Only(c, CLOCK_NAMES),
        "move_base": lambda m: Only(m, GOAL_CLIENT_NAMES),
        "dock_action": lambda a: Only(a, ACTION_NAMES),
        "undock_action": lambda a: Only(a, ACTION_NAMES),
        "robot_battery": lambda b: Only(b, BATTERY_NAMES),
        "laptop_battery": lambda b: Only(b, BATTERY_NAMES),
    })


def test_the_simulator_keeps_the_robot_protocol(make_patrol, b5203_poses):
    sim = make_patrol(list(b5203_poses.goals[:2])).sim
    assert isinstance(sim, PatrolRobot)
    assert isinstance(sim.clock, PatrolClock)
    assert isinstance(sim.move_base, GoalClient)
    assert isinstance(sim.dock_action, RobotAction) and isinstance(sim.undock_action, RobotAction)
    assert isinstance(sim.robot_battery, RobotBatteryView) and isinstance(sim.laptop_battery, BatteryView)
    assert sim.wall_clock is False
    report = sim.report()
    assert isinstance(report, RobotReport)
    assert (report.distance, report.collisions, report.localization) == (0.0, 0, "exact")


@pytest.mark.parametrize("case", ["aborted goal", "battery low, dock, resume"])
def test_the_machine_runs_on_the_protocol_alone(make_patrol, b5203_poses, case):
    """The same patrol on the bare simulator and on a view of it with the protocol only: same states, same
    machine events (the proxy fails the run if the machine or the runner touched anything else)."""
    if case == "aborted goal":
        goals = [b5203_poses.goals[0], IN_TABLE, b5203_poses.goals[2]]
        settings: dict[str, Any] = {"max_laps": 1}
    else:
        goals = list(b5203_poses.goals[:4])
        settings = {"robot_battery_percent": 28.2, "resume": True, "max_laps": 1}
    plain = make_patrol(goals, **settings)
    plain_summary = run_patrol(plain, handle_sigint=False)
    twin = make_patrol(goals, **settings)
    viewed = PatrolMachine(protocol_only(twin.sim), goals, STATION, max_laps=1,
                           resume_after_charging=settings.get("resume", False))
    viewed_summary = run_patrol(viewed, handle_sigint=False)
    assert viewed.entered == plain.entered
    assert machine_trace(twin.sim.events.events) == machine_trace(plain.sim.events.events)
    assert viewed_summary == replace(plain_summary, wall_time=viewed_summary.wall_time)
    trace = machine_trace(plain.sim.events.events)
    results = [t[1:] for t in trace if t[0] == "goal_result"]
    if case == "aborted goal":
        assert results == [("POSE_0", "SUCCEEDED"), ("POSE_1", "ABORTED"), ("POSE_2", "SUCCEEDED")]
    else:
        assert ("action_result", "DockAction", "SUCCEEDED") in trace
        assert ("action_result", "UndockAction", "SUCCEEDED") in trace
    assert trace[-1] == ("outcome", "shutdown")


def test_machine_trace_keeps_what_every_robot_shares():
    events = [{"t": 0.0, "type": "state_enter", "state": "A"}, {"t": 0.1, "type": "plan", "goal_id": 1},
              {"t": 2.5, "type": "goal_result", "goal_id": 7, "name": "POSE_0", "status": "ABORTED", "text": "x"},
              {"t": 3.0, "type": "lap", "laps": 1}]
    assert machine_trace(events) == [("state_enter", "A"), ("goal_result", "POSE_0", "ABORTED"), ("lap", 1)]


@pytest.mark.parametrize(("spec", "expected"), [
    ("sim", ("sim", {})),
    (" ROS1 , master=http://10.0.0.2:11311 ,pose=/amcl_pose", ("ros1", {"master": "http://10.0.0.2:11311",
                                                                         "pose": "/amcl_pose"})),
    ("ros1,dock=", ("ros1", {"dock": ""})),
])
def test_robot_specs_parse(spec, expected):
    assert parse_robot_spec(spec) == expected


@pytest.mark.parametrize(("spec", "needle"), [
    ("", "expected a robot name first"),
    (",master=x", "expected a robot name first"),
    ("ros1,master", "'master' is not key=value"),
    ("ros1,pose=/a,pose=/b", "option pose is given twice"),
])
def test_bad_robot_specs_are_one_line(spec, needle):
    with pytest.raises(RobotError, match=needle):
        parse_robot_spec(spec)


def test_sim_is_a_registered_robot(b5203_map):
    assert ROBOTS.get("sim") is SimulatedRobot
    with pytest.raises(RobotError, match=r"robot sim has no option speed \(options: none\)"):
        open_robot("sim,speed=2", None)  # type: ignore[arg-type]  # refused before the setup is read


def test_unknown_robot_on_the_command_line_is_one_error_line(capsys):
    assert main([POSES, "--map", MAP, "--laps", "1", "--robot", "nosuch"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith("objrec-patrol: error: --robot nosuch: no such robot (known: ") and "sim" in err


def test_robot_sim_is_the_default(capsys):
    assert main([POSES, "--map", MAP, "--laps", "1", "--robot", "sim"]) == 0
    chosen = capsys.readouterr().out
    assert main([POSES, "--map", MAP, "--laps", "1"]) == 0
    default = capsys.readouterr().out
    strip = [line for line in chosen.splitlines() if not line.startswith("simulated time")]
    assert strip == [line for line in default.splitlines() if not line.startswith("simulated time")]
    assert "45 reached" not in chosen and "15 reached, 0 aborted" in chosen
