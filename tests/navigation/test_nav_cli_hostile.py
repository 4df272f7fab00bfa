"""Hostile runs of objrec-patrol: every number refused in one line, SIGTERM handled like Ctrl-C, and degenerate
maps (one free cell, start in an obstacle, an unreachable goal, a huge map) ending with a clear outcome in
bounded time and memory; the planner's and the runner's own bounds underneath."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

import navigation
from navigation import cli
from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.maps import OccupancyMap
from navigation.move_base import KEPT_PLANS
from navigation.patrol import PatrolMachine
from navigation.planner import Planner, PlannerParams
from navigation.runner import PREEMPT_GRACE, StopSignals, run_patrol
from navigation.simulation import SimConfig, Simulation

DATA = Path(navigation.__file__).parent / "data"
POSES, MAP = str(DATA / "b5203.txt"), str(DATA / "b5203.yaml")
#: The small process that runs a command and reports its own peak memory (see tests/peak_memory.py).
PEAK_MEMORY = Path(__file__).resolve().parents[1] / "peak_memory.py"


def _peak_mb(report: Path) -> float:
    """The peak memory (MB) tests/peak_memory.py wrote for the command it ran; 0 when it wrote none."""
    try:
        return int(report.read_text()) / 1024.0
    except (OSError, ValueError):
        return 0.0


#: objrec-patrol as its console script runs it.
PATROL = [sys.executable, "-c", "import sys; from objrec_apps.launch import patrol; sys.exit(patrol())"]


def summary_fields(text: str) -> dict[str, str]:
    return {k.strip(): v.strip() for k, v in (line.split(":", 1) for line in text.strip().splitlines())}


def patrol(*args: str, timeout: float = 30.0) -> tuple[int, str, str, float, float]:
    """Run the command; exit code, stdout, stderr, wall seconds and the child's peak memory (MB)."""
    started = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.TemporaryDirectory() as folder:
        report = Path(folder) / "peak"
        process = subprocess.Popen([sys.executable, str(PEAK_MEMORY), str(report), *PATROL, *args],
                                   stdout=out, stderr=err)
        timer = threading.Timer(timeout, process.kill)
        timer.start()
        try:
            _, status, _usage = os.wait4(process.pid, 0)
        finally:
            timer.cancel()
        process.returncode = os.waitstatus_to_exitcode(status)
        elapsed = time.perf_counter() - started
        out.seek(0)
        err.seek(0)
        return process.returncode, out.read().decode(), err.read().decode(), elapsed, _peak_mb(report)


# -- numbers --------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("args", "message"), [
    (["--start", "nan", "12.8", "0"], "--start: X: nan is not a finite number"),
    (["--start", "14.4", "inf", "0"], "--start: Y: inf is not a finite number"),
    (["--start", "14.4", "12.8", "-inf"], "--start: YAW: -inf is not a finite number"),
    (["--margin", "NaN"], "--margin: NaN is not a finite number"),
    (["--seed", "-1"], "--seed: -1 is below the minimum 0"),
    (["--odom-noise", "-0.1"], "--odom-noise: -0.1 is below the minimum 0"),
    (["--odom-noise", "nan"], "--odom-noise: nan is not a finite number"),
    (["--dt", "0.0001"], "--dt: 0.0001 is below the minimum 0.01"),
])
def test_the_issues_numbers_are_one_line_and_exit_2(args, message):
    code, out, err, elapsed, _ = patrol(POSES, "--map", MAP, *args)
    assert code == 2 and out == ""
    assert err == f"objrec-patrol: error: {message}\n"
    assert elapsed < 10.0


@pytest.mark.parametrize(("args", "message"), [
    (["--start", "1e7", "0", "0"], "--start: X: 1e7 is above the maximum 1000000"),
    (["--start", "0", "0", "7"], "--start: YAW: 7 is above the maximum 6.28319"),
    (["--margin", "-0.2"], "--margin: -0.2 is below the minimum 0"),
    (["--seed", "1.5"], "--seed: 1.5 is not a whole number"),
    (["--seed", "4294967296"], "--seed: 4294967296 is above the maximum 4294967295"),
    (["--dt", "inf"], "--dt: inf is not a finite number"),
    (["--dt", "2"], "--dt: 2 is above the maximum 0.5"),
    (["--laps", "0"], "--laps: 0 is below the minimum 1"),
    (["--laps", "many"], "--laps: 'many' is not a whole number"),
    (["--time-limit", "0"], "--time-limit: 0 is not above 0"),
    (["--time-limit", "nan"], "--time-limit: nan is not a finite number"),
    (["--robot-battery", "101"], "--robot-battery: 101 is above the maximum 100"),
    (["--robot-battery-low", "-1"], "--robot-battery-low: -1 is below the minimum 0"),
    (["--robot-runtime", "0"], "--robot-runtime: 0 is below the minimum 0.01"),
    (["--robot-charge-time", "inf"], "--robot-charge-time: inf is not a finite number"),
    (["--laptop-battery", "nan"], "--laptop-battery: nan is not a finite number"),
    (["--laptop-battery-low", "100.5"], "--laptop-battery-low: 100.5 is above the maximum 100"),
    (["--laptop-runtime", "1e400"], "--laptop-runtime: 1e400 is above the maximum 1000"),
    (["--dock-distance", "0"], "--dock-distance: 0 is below the minimum 0.1"),
    (["--render", "a\nb.tiff"], r"--render a\nb.tiff: the extension must be one of"),
])
def test_every_number_is_checked_like_a_declared_parameter(args, message, capsys):
    with pytest.raises(SystemExit) as ended:
        cli.main([POSES, "--map", MAP, *args])
    assert ended.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"objrec-patrol: error: {message}") and err.count("\n") == 1


def test_a_bad_limit_variable_is_one_line(monkeypatch, capsys):
    monkeypatch.setenv("OBJREC_MAX_MAP_CELLS", "-5")
    assert cli.main([POSES, "--map", MAP, "--laps", "1"]) == 2
    err = capsys.readouterr().err
    assert err == ("objrec-patrol: error: environment variable OBJREC_MAX_MAP_CELLS: '-5' is not a whole number "
                   "of cells between 1 and 2**62\n")


# -- signals --------------------------------------------------------------------------------------------------------
def test_sigterm_shuts_down_like_ctrl_c(tmp_path):
    events = tmp_path / "e.jsonl"
    process = subprocess.Popen([*PATROL, POSES, "--map", MAP, "--realtime", "--events", str(events)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20.0
        while not (events.exists() and events.stat().st_size > 0) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=20.0)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert "Traceback" not in err
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown (SIGTERM)" and fields["final state"] == "SHUTDOWN"
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    assert {"t": lines[-1]["t"], "type": "outcome", "outcome": "shutdown"} == lines[-1]
    assert any(e["type"] == "state_enter" and e["state"] == "SHUTDOWN" for e in lines)
    assert any(e["type"] == "preempt_requested" and e["reason"] == "SIGTERM" for e in lines)


def test_sigterm_during_start_up_still_shuts_down(tmp_path, capsys, monkeypatch):
    real_load_map = cli.load_map

    def load_map_terminated(path):
        os.kill(os.getpid(), signal.SIGTERM)
        return real_load_map(path)

    monkeypatch.setattr(cli, "load_map", load_map_terminated)
    before = signal.getsignal(signal.SIGTERM)
    events = tmp_path / "e.jsonl"
    assert cli.main([POSES, "--map", MAP, "--events", str(events)]) == 0
    assert summary_fields(capsys.readouterr().out)["outcome"] == "shutdown (SIGTERM)"
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    assert lines[0] == {"t": 0.0, "type": "preempt_requested", "reason": "SIGTERM"}
    assert lines[-1]["type"] == "outcome" and lines[-1]["t"] < 1.0
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_second_signal_gives_up_at_once():
    with StopSignals() as flags:
        os.kill(os.getpid(), signal.SIGTERM)
        assert (flags.count, flags.reason) == (1, "SIGTERM")
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
        assert flags.reason == "SIGTERM"


# -- degenerate maps ------------------------------------------------------------------------------------------------
def write_map(folder: Path, name: str, image: np.ndarray, resolution: float) -> str:
    cv2.imwrite(str(folder / f"{name}.png"), image)
    (folder / f"{name}.yaml").write_text(f"image: {name}.png\nresolution: {resolution}\norigin: [0, 0, 0]\n"
                                         "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return str(folder / f"{name}.yaml")


def write_goals(folder: Path, *goals: tuple[float, float]) -> str:
    path = folder / "goals.txt"
    path.write_text("".join(f"{x}, {y}, 0, 0, 0, 0, 1\n" for x, y in goals))
    return str(path)


def one_free_cell() -> np.ndarray:
    image = np.zeros((5, 5), np.uint8)
    image[2, 2] = 254
    return image


def test_one_free_cell_and_a_goal_in_a_wall_end_in_bounded_time(tmp_path):
    occ_map = write_map(tmp_path, "one", one_free_cell(), 1.0)
    goals = write_goals(tmp_path, (2.5, 2.5), (0.5, 0.5))
    code, out, err, elapsed, _ = patrol(goals, "--map", occ_map, "--laps", "3")
    assert code == 0, err
    assert "goal POSE_1 (0.50, 0.50) is off the map or in an obstacle" in err
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown" and fields["laps"] == "3"
    assert fields["goals"] == "3 reached, 3 aborted, 0 preempted"
    assert elapsed < 10.0


def test_a_robot_too_big_for_the_only_free_cell_cannot_start(tmp_path):
    occ_map = write_map(tmp_path, "one", one_free_cell(), 0.05)
    goals = write_goals(tmp_path, (0.125, 0.125))
    code, out, err, elapsed, _ = patrol(goals, "--map", occ_map)
    assert code == 2 and out == "" and elapsed < 10.0
    assert err.count("\n") == 1 and "puts the robot (radius 0.18 m) off the map or inside an obstacle" in err


def test_a_goal_in_an_unreachable_room_is_aborted(tmp_path):
    image = np.full((60, 100), 254, np.uint8)
    image[:, 48:52] = 0
    image[0, :] = image[-1, :] = image[:, 0] = image[:, -1] = 0
    occ_map = write_map(tmp_path, "rooms", image, 0.05)
    goals = write_goals(tmp_path, (1.0, 1.5), (4.0, 1.5))
    code, out, err, elapsed, _ = patrol(goals, "--map", occ_map, "--laps", "1")
    assert code == 0, err
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown" and fields["goals"] == "1 reached, 1 aborted, 0 preempted"
    assert elapsed < 10.0


def test_a_huge_map_plans_in_bounded_time_and_memory(tmp_path):
    size = 1500  # 2.25 million cells, 75 m across
    image = np.full((size, size), 254, np.uint8)
    image[0, :] = image[-1, :] = image[:, 0] = image[:, -1] = 0
    occ_map = write_map(tmp_path, "huge", image, 0.05)
    goals = write_goals(tmp_path, (1.0, 1.0), (70.0, 70.0))
    code, out, err, elapsed, peak = patrol(goals, "--map", occ_map, "--laps", "1", timeout=60.0)
    assert code == 0, err
    assert summary_fields(out)["goals"] == "2 reached, 0 aborted, 0 preempted"
    assert elapsed < 10.0
    assert peak < 500.0


# -- the bounds underneath ------------------------------------------------------------------------------------------
def open_map(size: int) -> OccupancyMap:
    data = np.zeros((size, size), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyMap(data, 0.05)


def test_landmarks_are_budgeted_by_map_size():
    field = ObstacleField(open_map(300))  # 90,000 cells
    assert len(Planner(field)._landmarks) == 6
    assert len(Planner(field, PlannerParams(landmark_budget=250_000))._landmarks) == 2
    assert Planner(field, PlannerParams(landmark_budget=150_000))._landmarks == []  # one would not pay


def test_a_search_past_its_budget_is_a_failed_plan():
    field = ObstacleField(open_map(200))
    start, goal = Pose2D(1.0, 1.0, 0.0), Pose2D(9.0, 9.0, 0.0)
    plan = Planner(field, PlannerParams(max_expansions=50)).plan(start, goal)
    assert not plan.ok and plan.reason == "no path found within 50 expanded cells"
    assert plan.expansions == 51
    assert Planner(field).plan(start, goal).ok


def test_planner_tables_share_their_values():
    planner = Planner(ObstacleField(open_map(300)), PlannerParams(landmarks=0))
    costs, w = planner._cost, planner.field.width
    assert len({id(c) for c in costs}) == len(set(costs)) < 1000  # one object per distinct value
    assert planner._col[280] is planner._col[280 + 7 * w] and planner._row[280 * w] is planner._row[280 * w + 9]
    assert (planner._col[280 + 7 * w], planner._row[280 * w + 9]) == (280, 280)


def test_a_run_flat_out_ends_at_the_step_limit(b5203_map):
    station = Pose2D(14.4, 12.8, 0.0)
    sim = Simulation(b5203_map, station, replace(SimConfig(), dt=0.01))
    machine = PatrolMachine(sim, [Pose2D(12.0, 12.8, 0.0), station], None)
    summary = run_patrol(machine, handle_sigint=False, max_steps=400)
    assert summary.outcome == "shutdown" and summary.final_states == ("SHUTDOWN",)
    assert summary.preempt_reason == "step limit of 400 steps"
    assert 400 <= sim.clock.steps <= 400 + PREEMPT_GRACE / 0.01 + 1


def test_kept_plans_are_bounded(tmp_path):
    occ_map = OccupancyMap(np.where(one_free_cell()[::-1] > 0, 0, 100), 1.0)
    sim = Simulation(occ_map, Pose2D(2.5, 2.5, 0.0), SimConfig(record_every=0))
    goals = [Pose2D(2.5, 2.5, 0.0), Pose2D(0.5, 0.5, 0.0)]
    machine = PatrolMachine(sim, goals, None, max_laps=KEPT_PLANS)
    summary = run_patrol(machine, handle_sigint=False)
    assert summary.laps == KEPT_PLANS and summary.goals_aborted == KEPT_PLANS
    assert len(sim.move_base.plans) == KEPT_PLANS < 2 * KEPT_PLANS
