"""Hostile runs of objrec-patrol: every number refused in one line, and degenerate maps (one free cell, start in
an obstacle, an unreachable goal, a huge map) ending with a clear outcome in bounded time and memory; the
planner's and the runner's own bounds underneath. SIGTERM, handled like Ctrl-C, is tested in test_nav_cli.py."""

from __future__ import annotations

import sys
import tempfile
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
from navigation.runner import PREEMPT_GRACE, run_patrol
from navigation.simulation import SimConfig, Simulation
from tests.hostile import harness

DATA = Path(navigation.__file__).parent / "data"
POSES, MAP = str(DATA / "b5203.txt"), str(DATA / "b5203.yaml")
#: CPU seconds a run may take (tests/hostile/harness.py measures them; wall-clock is only its hang guard).
CPU_SECONDS_LIMIT = harness.CPU_SECONDS_LIMIT


#: objrec-patrol as its console script runs it.
PATROL = [sys.executable, "-c", "import sys; from objrec_apps.launch import patrol; sys.exit(patrol())"]


def summary_fields(text: str) -> dict[str, str]:
    return {k.strip(): v.strip() for k, v in (line.split(":", 1) for line in text.strip().splitlines())}


def patrol(*args: str) -> tuple[int | None, str, str, float, float]:
    """Run the command in a fresh folder (tests/hostile/harness.py); exit code (None: killed at a bound), stdout,
    stderr, the child's CPU seconds and its own peak memory (MB)."""
    with tempfile.TemporaryDirectory() as folder:
        run = harness.run([*PATROL, *args], Path(folder))
    return run.exit_code, run.stdout, run.stderr, run.cpu_seconds, run.max_rss_mb


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
    code, out, err, cpu, _ = patrol(POSES, "--map", MAP, *args)
    assert code == 2 and out == ""
    assert err == f"objrec-patrol: error: {message}\n"
    assert cpu < CPU_SECONDS_LIMIT


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
    code, out, err, cpu, _ = patrol(goals, "--map", occ_map, "--laps", "3")
    assert code == 0, err
    assert "goal POSE_1 (0.50, 0.50) is off the map or in an obstacle" in err
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown" and fields["laps"] == "3"
    assert fields["goals"] == "3 reached, 3 aborted, 0 preempted"
    assert cpu < CPU_SECONDS_LIMIT


def test_a_robot_too_big_for_the_only_free_cell_cannot_start(tmp_path):
    occ_map = write_map(tmp_path, "one", one_free_cell(), 0.05)
    goals = write_goals(tmp_path, (0.125, 0.125))
    code, out, err, cpu, _ = patrol(goals, "--map", occ_map)
    assert code == 2 and out == "" and cpu < CPU_SECONDS_LIMIT
    assert err.count("\n") == 1 and "puts the robot (radius 0.18 m) off the map or inside an obstacle" in err


def test_a_goal_in_an_unreachable_room_is_aborted(tmp_path):
    image = np.full((60, 100), 254, np.uint8)
    image[:, 48:52] = 0
    image[0, :] = image[-1, :] = image[:, 0] = image[:, -1] = 0
    occ_map = write_map(tmp_path, "rooms", image, 0.05)
    goals = write_goals(tmp_path, (1.0, 1.5), (4.0, 1.5))
    code, out, err, cpu, _ = patrol(goals, "--map", occ_map, "--laps", "1")
    assert code == 0, err
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown" and fields["goals"] == "1 reached, 1 aborted, 0 preempted"
    assert cpu < CPU_SECONDS_LIMIT


def test_a_huge_map_plans_in_bounded_time_and_memory(tmp_path):
    size = 1500  # 2.25 million cells, 75 m across
    image = np.full((size, size), 254, np.uint8)
    image[0, :] = image[-1, :] = image[:, 0] = image[:, -1] = 0
    occ_map = write_map(tmp_path, "huge", image, 0.05)
    goals = write_goals(tmp_path, (1.0, 1.0), (70.0, 70.0))
    code, out, err, cpu, peak = patrol(goals, "--map", occ_map, "--laps", "1")
    assert code == 0, err
    assert summary_fields(out)["goals"] == "2 reached, 0 aborted, 0 preempted"
    assert cpu < CPU_SECONDS_LIMIT
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
