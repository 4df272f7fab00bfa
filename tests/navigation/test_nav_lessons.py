"""Nav2's classic lessons without ROS: door width vs inflation, keepout and speed zones, controller settings.

Simulated time only: every figure here is in cells, metres and simulation steps.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from declare.fields import DocumentError
from navigation.cli import main
from navigation.costmap import ObstacleField
from navigation.costmap_filters import SpeedLimitInfo, SpeedZones, keepout_cells, load_keepout, load_speed_zones
from navigation.geometry import Pose2D
from navigation.maps import FREE, OCCUPIED, OccupancyMap, load_map, save_map
from navigation.move_base import GoalStatus
from navigation.nav_params import NavParams, apply_to_simulation, read_nav_params
from navigation.patrol import PatrolMachine
from navigation.planner import Planner, PlannerParams
from navigation.poses import load_poses
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation

RES = 0.05
RADIUS = 0.18


def door_map(width: float) -> OccupancyMap:
    """Two 3 x 4 m rooms joined by a door of ``width`` (whole cells, centred at y = 2) in a 0.2 m wall."""
    data = np.full((80, 120), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    data[:, 58:62] = OCCUPIED
    n = round(width / RES)
    data[40 - n // 2:40 - n // 2 + n, 58:62] = FREE
    return OccupancyMap(data, RES)


def room(width: float = 6.0, height: float = 3.0) -> OccupancyMap:
    data = np.full((round(height / RES), round(width / RES)), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    return OccupancyMap(data, RES)


def box_mask(occ_map: OccupancyMap, x0: float, y0: float, x1: float, y1: float, value: int) -> np.ndarray:
    mask = np.zeros(occ_map.data.shape, np.int8)
    mask[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = value
    return mask


def drive(sim: Simulation, goal: Pose2D, steps: int = 1500) -> list[tuple[GoalStatus, str]]:
    got: list[tuple[GoalStatus, str]] = []
    sim.move_base.send_goal(goal, lambda status, text: got.append((status, text)), name="g")
    for _ in range(steps):
        sim.step()
        if got:
            break
    return got


def disc_overlaps(cells: np.ndarray, x: float, y: float, radius: float) -> bool:
    """Whether a disc overlaps any True cell (cell squares of side RES, origin 0)."""
    jj, ii = np.nonzero(cells)
    dx = np.maximum(np.maximum(ii * RES - x, x - (ii + 1) * RES), 0.0)
    dy = np.maximum(np.maximum(jj * RES - y, y - (jj + 1) * RES), 0.0)
    return bool(np.any(dx * dx + dy * dy < radius * radius))


def path_points(path: np.ndarray, step: float = 0.01) -> list[tuple[float, float]]:
    out = []
    for p, q in itertools.pairwise(path):
        n = max(2, math.ceil(np.hypot(*(q - p)) / step) + 1)
        out += [tuple(p + t * (q - p)) for t in np.linspace(0.0, 1.0, n)]
    return out


# -- door width vs inflation ----------------------------------------------------------------------------
def test_a_door_needs_twice_the_inflation_plus_one_cell():
    """Radius 0.18 + margin 0.10 = 0.28 m each side: 0.56 m, plus the half cell each side the grid loses,
    so on a 5 cm map 0.60 m (12 cells) is closed and 0.65 m (13 cells) is open, for the planner and the robot."""
    closed = Planner(ObstacleField(door_map(0.60))).plan(Pose2D(1.5, 2.0), Pose2D(4.5, 2.0))
    assert not closed.ok
    opened = Planner(ObstacleField(door_map(0.65))).plan(Pose2D(1.5, 2.0), Pose2D(4.5, 2.0))
    assert opened.ok
    sim = Simulation(door_map(0.65), Pose2D(1.5, 2.0, 0.0), SimConfig(record_every=0))
    assert drive(sim, Pose2D(4.5, 2.0, 0.0))[0][0] == GoalStatus.SUCCEEDED
    assert sim.collisions == 0


def test_no_path_names_the_door_and_the_margin_that_opens_it():
    plan = Planner(ObstacleField(door_map(0.60))).plan(Pose2D(1.5, 2.0), Pose2D(4.5, 2.0))
    reason = plan.reason
    assert reason.startswith("no path: the goal lies in a region the start cannot reach")
    assert "near (2.93, 1.98)" in reason  # in the door: x 2.9..3.1, y 1.7..2.3
    assert "about 0.60 m wide" in reason
    assert "0.275 m each side" in reason and "planning keeps 0.280 m" in reason
    assert "inflation margin of 0.09 m or less opens it" in reason
    # and it does: the margin the message names opens the door
    assert Planner(ObstacleField(door_map(0.60)), PlannerParams(inflation_margin=0.09)).plan(
        Pose2D(1.5, 2.0), Pose2D(4.5, 2.0)).ok


def test_no_path_through_a_door_narrower_than_the_robot_says_so():
    reason = Planner(ObstacleField(door_map(0.30))).plan(Pose2D(1.5, 2.0), Pose2D(4.5, 2.0)).reason
    assert "about 0.30 m wide" in reason and "narrower than the robot itself" in reason


def test_no_path_to_a_walled_off_room_blames_the_wall_not_the_inflation():
    reason = Planner(ObstacleField(door_map(0.0))).plan(Pose2D(1.5, 2.0), Pose2D(4.5, 2.0)).reason
    assert reason == "no path: the goal lies in a region the start cannot reach"  # no passage to name


def test_cost_scaling_factor_moves_the_path_off_the_wall():
    """A slow decay (small factor) keeps the path in the middle of a 1.4 m corridor longer than a fast one."""
    corridor = room(6.0, 1.4)
    start, goal = Pose2D(0.6, 0.45), Pose2D(5.4, 0.45)
    slow = NavParams(cost_scaling_factor=1.0).planner_params(PlannerParams(smooth=False))
    fast = NavParams(cost_scaling_factor=50.0).planner_params(PlannerParams(smooth=False))
    y_slow = Planner(ObstacleField(corridor), slow).plan(start, goal).path[:, 1]
    y_fast = Planner(ObstacleField(corridor), fast).plan(start, goal).path[:, 1]
    assert np.median(y_slow) == pytest.approx(0.7, abs=0.06)  # the middle
    assert np.median(y_fast) < 0.55  # hugs the lethal zone's edge (0.05 + 0.28 + half a cell)


# -- keepout zone ----------------------------------------------------------------------------------------
def keepout_room() -> tuple[OccupancyMap, np.ndarray]:
    m = room()
    return m, box_mask(m, 2.5, 0.9, 3.5, 2.1, OCCUPIED) >= 65


def test_keepout_zone_no_planned_or_driven_cell_inside_it():
    m, keepout = keepout_room()
    field = ObstacleField(m)
    start, goal = Pose2D(0.7, 1.5, 0.0), Pose2D(5.3, 1.5, 0.0)
    assert np.hypot(*(Planner(field).plan(start, goal).path[-1] - [5.3, 1.5])) < 0.2  # straight through, without
    planner = Planner(field, PlannerParams(keepout=keepout))
    plan = planner.plan(start, goal)
    assert plan.ok
    assert not any(disc_overlaps(keepout, x, y, RADIUS) for x, y in path_points(plan.path))
    sim = Simulation(m, start, SimConfig(), field_=field, planner=planner)
    assert drive(sim, goal)[0][0] == GoalStatus.SUCCEEDED
    driven = [(x, y) for _, x, y, _ in sim.trajectory]
    assert len(driven) > 100
    assert not any(disc_overlaps(keepout, x, y, RADIUS) for x, y in driven)
    assert sim.collisions == 0


def test_goal_or_start_in_a_keepout_zone_is_named():
    m, keepout = keepout_room()
    planner = Planner(ObstacleField(m), PlannerParams(keepout=keepout))
    assert planner.plan(Pose2D(0.7, 1.5), Pose2D(3.0, 1.5)).reason == "goal is in a keepout zone"
    assert planner.plan(Pose2D(3.0, 1.5), Pose2D(0.7, 1.5)).reason == "start is in a keepout zone"
    assert planner.plan(Pose2D(0.7, 1.5), Pose2D(0.02, 1.5)).reason == "goal is in an obstacle"


def test_keepout_mask_file_in_nav2_format_at_its_own_resolution(tmp_path: Path):
    """A trinary mask at 0.1 m with its own origin lands on the right cells of a 0.05 m map."""
    m = room()
    mask = np.zeros((15, 30), np.int8)  # 3 x 1.5 m at 0.1 m, origin (1, 0.5)
    mask[4:10, 15:25] = OCCUPIED  # world x 2.5..3.5, y 0.9..1.5
    save_map(OccupancyMap(mask, 0.1, Pose2D(1.0, 0.5, 0.0)), tmp_path / "keepout.yaml")
    cells = load_keepout(tmp_path / "keepout.yaml", m)
    assert cells.sum() == 20 * 12
    assert cells[round(1.2 / RES), round(3.0 / RES)] and not cells[round(1.6 / RES), round(3.0 / RES)]
    assert not keepout_cells(OccupancyMap(mask, 0.1, Pose2D(50.0, 50.0, 0.0)), m).any()  # a mask elsewhere


# -- speed zone ------------------------------------------------------------------------------------------
def test_speed_zone_caps_the_speed_there_and_only_there(tmp_path: Path):
    """Nav2's percent filter, base 100, multiplier -1: mask value 60 is 40 % of 0.5 m/s, 0.2 m/s."""
    m = room()
    save_map(OccupancyMap(box_mask(m, 2.5, 0.0, 3.5, 3.0, 60), RES), tmp_path / "speed.yaml", mode="raw")
    zones = load_speed_zones(tmp_path / "speed.yaml", m, SpeedLimitInfo(), max_speed=0.5, acceleration=1.0)
    assert zones.limit_at(3.0, 1.5) == pytest.approx(0.2)
    assert zones.limit_at(1.0, 1.5) == math.inf
    sim = Simulation(m, Pose2D(0.7, 1.5, 0.0), SimConfig())
    sim.move_base.speed_limit = zones.cap
    assert drive(sim, Pose2D(5.3, 1.5, 0.0))[0][0] == GoalStatus.SUCCEEDED
    traj = np.array(sim.trajectory)
    speed = np.hypot(np.diff(traj[:, 1]), np.diff(traj[:, 2])) / np.diff(traj[:, 0])
    mid_x = 0.5 * (traj[1:, 1] + traj[:-1, 1])
    inside = (mid_x >= 2.5) & (mid_x <= 3.5)
    assert inside.sum() >= 40  # 1 m at 0.2 m/s and 0.1 s steps: about 50 steps
    assert speed[inside].max() <= 0.2 + 1e-9
    assert speed[~inside].max() >= 0.45  # full speed outside


def test_speed_cap_keeps_the_arc_and_the_absolute_type():
    m = room()
    zones = SpeedZones.from_mask(OccupancyMap(box_mask(m, 2.5, 0.0, 3.5, 3.0, 30), RES), m,
                                 SpeedLimitInfo("absolute", 0.0, 0.01), max_speed=0.5, acceleration=1.0)
    assert zones.limit_at(3.0, 1.0) == pytest.approx(0.3)
    assert zones.cap(Pose2D(3.0, 1.0, 0.0), 0.5, 1.0, 0.1) == pytest.approx((0.3, 0.6))
    assert zones.cap(Pose2D(1.0, 1.0, 0.0), 0.5, 1.0, 0.1) == (0.5, 1.0)  # far from the zone
    assert zones.cap(Pose2D(2.4, 1.0, 0.0), 0.5, 0.0, 0.1)[0] == pytest.approx(0.3)  # within braking reach
    assert zones.cap(Pose2D(2.4, 1.0, math.pi), 0.5, 0.0, 0.1)[0] == 0.5  # heading away


# -- the parameters file ---------------------------------------------------------------------------------
def test_parameters_file_sets_planner_controller_and_filters(tmp_path: Path):
    save_map(OccupancyMap(box_mask(room(), 2.5, 0.9, 3.5, 2.1, OCCUPIED), RES), tmp_path / "keepout.yaml")
    (tmp_path / "nav.yaml").write_text(
        "planner:\n  inflation_margin: 0.05\n  cost_scaling_factor: 4\n"
        "controller:\n  max_speed: 0.3\n  acceleration: 0.8\n  lookahead: 0.5\n"
        "filters:\n  keepout_mask: keepout.yaml\n  speed_limit: {type: absolute, base: 0, multiplier: 0.01}\n")
    params = read_nav_params(tmp_path / "nav.yaml")
    assert params.keepout_mask == tmp_path / "keepout.yaml"
    assert params.speed_limit == SpeedLimitInfo("absolute", 0.0, 0.01)
    planner_params = params.planner_params(PlannerParams())
    assert (planner_params.inflation_margin, planner_params.cost_decay) == (0.05, 0.25)
    follower = params.follower_params(SimConfig().follower)
    assert (follower.max_linear, follower.linear_accel, follower.lookahead) == (0.3, 0.8, 0.5)
    # applied: the robot drives round the keepout zone and never faster than 0.3 m/s
    m = room()
    config = replace(SimConfig(), inflation_margin=0.05, follower=follower)
    sim = Simulation(m, Pose2D(0.7, 1.5, 0.0), config)
    apply_to_simulation(sim, params)
    assert sim.planner.params.keepout is not None and sim.move_base.planner is sim.planner
    assert drive(sim, Pose2D(5.3, 1.5, 0.0))[0][0] == GoalStatus.SUCCEEDED
    traj = np.array(sim.trajectory)
    assert (np.hypot(np.diff(traj[:, 1]), np.diff(traj[:, 2])) / np.diff(traj[:, 0])).max() <= 0.3 + 1e-9
    assert traj[:, 2].min() < 0.9 or traj[:, 2].max() > 2.1  # went round


@pytest.mark.parametrize(("text", "line", "message"), [
    ("planner:\n  inflation_marg: 0.1\n", 2, "planner.inflation_marg: unknown key (allowed: inflation_margin, "
                                             "cost_scaling_factor)"),
    ("controller:\n  lookahead: 0.3\n  max_speed: 0.8\n", 3, "controller.max_speed: 0.8 is invalid"),
    ("filters:\n  speed_limit:\n    type: fast\n", 3, "filters.speed_limit.type: 'fast' is invalid"),
    ("planner: 3\n", 1, "planner: 3 is invalid: expected a mapping"),
])
def test_parameters_file_errors_name_file_line_and_key(tmp_path: Path, text: str, line: int, message: str):
    path = tmp_path / "nav.yaml"
    path.write_text(text)
    with pytest.raises(DocumentError) as err:
        read_nav_params(path)
    assert str(err.value).startswith(f"{path}:{line}: {message}")
    assert "\n" not in str(err.value)


def test_missing_mask_file_is_named(tmp_path: Path):
    (tmp_path / "nav.yaml").write_text("filters:\n  keepout_mask: nowhere.yaml\n")
    with pytest.raises(DocumentError, match=r"nowhere\.yaml"):
        read_nav_params(tmp_path / "nav.yaml").keepout(room())


# -- the shipped exercise on room B5.2.03 ----------------------------------------------------------------
DATA = Path(__file__).resolve().parents[2] / "navigation" / "data"


def b5203_patrol_with_zones() -> Simulation:
    occ_map, poses = load_map(DATA / "b5203.yaml"), load_poses(DATA / "b5203.txt")
    params = read_nav_params(DATA / "b5203_nav.yaml")
    config = replace(SimConfig(), follower=params.follower_params(SimConfig().follower))
    sim = Simulation(occ_map, poses.goals[0], config)
    assert apply_to_simulation(sim, params) is not None  # a picture layer: there are zones to draw
    summary = run_patrol(PatrolMachine(sim, poses.goals, None, max_laps=1), handle_sigint=False)
    assert (summary.goals_reached, summary.goals_aborted, summary.collisions) == (15, 0, 0)
    return sim


def test_b5203_exercise_keeps_out_and_slows_down():
    """The shipped masks: no driven cell in the keepout zone, at most 0.2 m/s (40 %) in the speed zone."""
    sim = b5203_patrol_with_zones()
    traj = np.array(sim.trajectory)
    keepout = sim.planner.keepout[1:-1, 1:-1]  # the planner's padded grid, back to the map's
    ii, jj = np.floor(traj[:, 1] / RES).astype(int), np.floor(traj[:, 2] / RES).astype(int)
    assert not keepout[jj, ii].any()
    assert min(np.hypot(np.clip(x, 12.6, 13.4) - x, np.clip(y, 12.9, 15.0) - y) for _, x, y, _ in traj) >= RADIUS
    speed = np.hypot(np.diff(traj[:, 1]), np.diff(traj[:, 2])) / np.diff(traj[:, 0])
    mx, my = 0.5 * (traj[1:, 1] + traj[:-1, 1]), 0.5 * (traj[1:, 2] + traj[:-1, 2])
    inside = (mx >= 12.0) & (mx <= 15.0) & (my >= 9.9) & (my <= 11.8)
    assert inside.sum() > 50
    assert speed[inside].max() <= 0.2 + 1e-9
    assert speed[~inside].max() > 0.4


def test_patrol_command_takes_the_parameters_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    picture = tmp_path / "zones.png"
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--laps", "1",
                 "--nav-params", str(DATA / "b5203_nav.yaml"), "--render", str(picture)])
    out = capsys.readouterr().out
    assert code == 0 and "15 reached, 0 aborted" in out and "collisions:     0" in out
    image = cv2.imread(str(picture))
    assert np.all(image == (60, 60, 220), axis=-1).sum() == 0  # blended, not painted over
    assert np.any(np.all(np.abs(image.astype(int) - (133, 133, 220)) <= 30, axis=-1))  # keepout tint over floor


def test_patrol_command_bad_parameters_file_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    bad = tmp_path / "nav.yaml"
    bad.write_text("controller:\n  max_speed: 0.9\n")
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--nav-params", str(bad)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and f"{bad}:2: controller.max_speed: 0.9 is invalid" in err


def test_a_goal_in_a_keepout_zone_is_aborted_at_once_with_its_reason():
    m, keepout = keepout_room()
    field = ObstacleField(m)
    sim = Simulation(m, Pose2D(0.7, 1.5, 0.0), SimConfig(), field_=field,
                     planner=Planner(field, PlannerParams(keepout=keepout)))
    assert drive(sim, Pose2D(3.0, 1.5, 0.0)) == [(GoalStatus.ABORTED, "goal is in a keepout zone")]
    assert not sim.events.of_type("recovery")
    assert sim.clock.now <= 0.5


def test_patrol_warns_about_a_goal_in_the_keepout_zone(tmp_path: Path, caplog: pytest.LogCaptureFixture):
    poses = tmp_path / "poses.txt"
    poses.write_text("10.69, 14.15, 0, 0, 0, 0, 1\n13.0, 14.0, 0, 0, 0, 0, 1\n")
    code = main([str(poses), "--map", str(DATA / "b5203.yaml"), "--laps", "1",
                 "--keepout-mask", str(DATA / "b5203_keepout.yaml")])
    assert code == 0
    assert "goal POSE_1 (13.00, 14.00) is in a keepout zone; it will be aborted" in caplog.text


def test_an_output_may_not_replace_a_mask(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    mask = save_map(OccupancyMap(box_mask(room(), 2.5, 0.9, 3.5, 2.1, OCCUPIED), RES), tmp_path / "keepout.yaml")
    before = mask.read_bytes()
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--keepout-mask", str(mask),
                 "--events", str(mask)])
    assert code == 2 and "it is the file of --keepout-mask of this run" in capsys.readouterr().err
    assert mask.read_bytes() == before


def test_a_rotated_mask_lands_where_its_origin_puts_it():
    """Mask origin (3, 0) turned 90 degrees: its column axis is the map's +y, its row axis the map's -x."""
    mask = np.zeros((10, 10), np.int8)
    mask[2, 5] = OCCUPIED  # u 0.5..0.6 (along +y), v 0.2..0.3 (along -x): x 2.7..2.8, y 0.5..0.6
    cells = keepout_cells(OccupancyMap(mask, 0.1, Pose2D(3.0, 0.0, math.pi / 2)), room())
    assert np.argwhere(cells).tolist() == [[10, 54], [10, 55], [11, 54], [11, 55]]
