"""Driving among things the map does not know: the laser's costmap, replanning, recovery, bounded aborts.

The simulated world (what the robot bumps into and the laser sees) is given as ``field_``; the planner is
built on the map as it was drawn, without the extra obstacles, as on a robot whose map is out of date.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from navigation.costmap import ObstacleField
from navigation.follower import FollowerParams, PathFollower
from navigation.geometry import Pose2D
from navigation.laser import LaserParams, LaserScan, cast_scan
from navigation.local_costmap import LocalCostmap
from navigation.maps import FREE, OCCUPIED, OccupancyMap
from navigation.move_base import RECOVERY_BEHAVIOURS, GoalStatus, MoveBaseParams
from navigation.planner import Planner
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation

RES = 0.05
RADIUS = 0.18
Box = tuple[float, float, float, float]


def room(width: float, height: float, boxes: tuple[Box, ...] = ()) -> OccupancyMap:
    """A walled room: free inside, one-cell walls on the border, occupied boxes (x0, y0, x1, y1)."""
    w, h = round(width / RES), round(height / RES)
    data = np.full((h, w), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    for x0, y0, x1, y1 in boxes:
        data[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = OCCUPIED
    return OccupancyMap(data, RES, Pose2D(0.0, 0.0, 0.0))


def make_sim(world: OccupancyMap, mapped: OccupancyMap, start: Pose2D, laser: bool = True,
             **config: object) -> Simulation:
    """The robot lives in ``world`` but plans on ``mapped``; ``laser`` gives move_base the scans."""
    sim = Simulation(world, start, SimConfig(**config), field_=ObstacleField(world),  # type: ignore[arg-type]
                     planner=Planner(ObstacleField(mapped)))
    if laser:
        sim.move_base.use_laser(sim.scan, sim.config.laser)
    else:
        sim.move_base.scan_source = None
    return sim


def drive(sim: Simulation, goal: Pose2D, limit: float = 300.0) -> tuple[float, GoalStatus, str]:
    """Send one goal and step until its result arrives: (time, status, text)."""
    got: list[tuple[float, GoalStatus, str]] = []
    sim.move_base.send_goal(goal, lambda s, t: got.append((sim.clock.now, s, t)), name="goal")
    while not got and sim.clock.now < limit:
        sim.step()
    assert got, f"no result within {limit} s"
    return got[0]


def distance_to_box(x: np.ndarray, y: np.ndarray, box: Box) -> np.ndarray:
    x0, y0, x1, y1 = box
    dx = np.maximum(np.maximum(x0 - x, x - x1), 0.0)
    dy = np.maximum(np.maximum(y0 - y, y - y1), 0.0)
    return np.hypot(dx, dy)


def closest_approach(sim: Simulation, box: Box) -> float:
    track = np.array(sim.trajectory)
    return float(distance_to_box(track[:, 1], track[:, 2], box).min())


# -- avoiding what the map does not show ----------------------------------------------------------------
EMPTY = room(8.0, 4.0)


@pytest.mark.parametrize("box", [(3.8, 1.6, 4.2, 2.4),    # half-way, across the straight path
                                 (1.7, 1.8, 2.1, 2.2),    # 0.52 m in front of the robot at the start
                                 (5.0, 1.9, 5.6, 3.0)])   # off-centre, touching the path from one side
def test_unmapped_box_on_the_path_is_avoided_without_collision(box):
    start, goal = Pose2D(1.0, 2.0, 0.0), Pose2D(7.0, 2.0, 0.0)
    world = room(8.0, 4.0, boxes=(box,))
    sim = make_sim(world, EMPTY, start)
    t, status, text = drive(sim, goal)
    assert (status, text) == (GoalStatus.SUCCEEDED, "goal reached")
    assert sim.collisions == 0
    assert sim.robot.pose.distance_to(goal) <= 0.15
    assert closest_approach(sim, box) >= RADIUS + 0.02
    assert t < 25.0  # 6 m at 0.5 m/s plus the detour
    # The map's path runs through the box; the laser made move_base plan round it: at once when the
    # first scan already showed it, else when the box came within the window ahead.
    path = sim.planner.plan(start, goal).path
    along = np.concatenate([np.linspace(a, b, 100) for a, b in itertools.pairwise(path)])
    assert distance_to_box(along[:, 0], along[:, 1], box).min() < RADIUS
    plans = sim.events.of_type("plan")
    assert all(p["ok"] for p in plans) and any(p["avoiding"] > 0 for p in plans)
    blocked = sim.events.of_type("path_blocked")
    assert len(blocked) == (plans[0]["avoiding"] == 0)
    for event in blocked:
        assert distance_to_box(np.array(event["x"]), np.array(event["y"]), box) < RADIUS + 0.05 + RES
        assert 0 < event["ahead"] <= 2.0 * math.sqrt(2) and event["obstacles"] > 0
        # It stopped to watch the way for a second; nothing moved, so it planned round the box.
        assert event["action"] == "wait"
        detour = next(p for p in plans if p["avoiding"] > 0)
        assert detour["t"] - event["t"] == pytest.approx(sim.move_base.params.look_time, abs=0.11)
    assert not sim.events.of_type("path_clear")
    assert not sim.events.of_type("recovery")


def test_without_the_laser_the_same_box_is_a_collision():
    """The contrast: driving on the map alone runs into the box, recovers, and gives up."""
    box = (3.8, 1.6, 4.2, 2.4)
    sim = make_sim(room(8.0, 4.0, boxes=(box,)), EMPTY, Pose2D(1.0, 2.0, 0.0), laser=False)
    _, status, text = drive(sim, Pose2D(7.0, 2.0, 0.0))
    assert status == GoalStatus.ABORTED and text.startswith("no progress for 10 s")
    assert sim.collisions >= 1
    assert sim.move_base.costmap.scans == 0


@pytest.mark.parametrize(("y0", "speed"), [(1.0, 0.3), (1.2, 0.2), (1.4, 0.3)])
def test_a_box_crossing_the_way_is_waited_for(y0, speed):
    """A box slides across the corridor in front of the robot: it stops, lets it pass, and drives on."""
    fields: dict[int, ObstacleField] = {}

    def box_at(y: float) -> ObstacleField:  # the world with the box's centre at height y (5 cm steps)
        k = round(y / RES)
        if k not in fields:
            fields[k] = ObstacleField(room(8.0, 4.0, boxes=((3.6, k * RES - 0.2, 4.0, k * RES + 0.2),)))
        return fields[k]

    sim = make_sim(EMPTY, EMPTY, Pose2D(1.0, 2.0, 0.0))
    got: list[GoalStatus] = []
    sim.move_base.send_goal(Pose2D(7.0, 2.0, 0.0), lambda s, _t: got.append(s))
    while not got and sim.clock.now < 60.0:
        sim.field = box_at(min(3.5, y0 + speed * sim.clock.now))  # what collisions and the laser see now
        sim.step()
    assert got == [GoalStatus.SUCCEEDED]
    assert sim.collisions == 0
    blocked, clear = sim.events.of_type("path_blocked"), sim.events.of_type("path_clear")
    assert [b["action"] for b in blocked] == ["wait"] and len(clear) == 1
    assert sim.move_base.params.look_time < clear[0]["waited"] <= sim.move_base.params.yield_time
    track = np.array(sim.trajectory)
    assert np.abs(track[:, 2] - 2.0).max() < 0.05  # it waited instead of swerving
    assert not sim.events.of_type("recovery")


def test_blocked_doorway_replans_through_the_other_one():
    """The map's way through the lower doorway is blocked; move_base replans through the upper one."""
    wall = ((2.9, 0.0, 3.1, 0.5), (2.9, 1.3, 3.1, 2.7), (2.9, 3.5, 3.1, 4.0))  # doorways at y 0.5-1.3, 2.7-3.5
    mapped = room(6.0, 4.0, boxes=wall)
    world = room(6.0, 4.0, boxes=(*wall, (2.9, 0.5, 3.1, 1.3)))  # the lower one has been closed
    sim = make_sim(world, mapped, Pose2D(1.0, 0.9, 0.0))
    goal = Pose2D(5.0, 0.9, 0.0)
    assert sim.planner.plan(sim.robot.pose, goal).path[:, 1].max() < 1.3  # the map's way: the lower doorway
    _, status, _ = drive(sim, goal)
    assert status == GoalStatus.SUCCEEDED
    assert sim.collisions == 0
    track = np.array(sim.trajectory)
    at_wall = track[np.abs(track[:, 1] - 3.0) < 0.1]
    assert len(at_wall) and np.all((at_wall[:, 2] > 2.7) & (at_wall[:, 2] < 3.5))  # through the upper door
    assert not sim.events.of_type("recovery")


def test_blocked_corridor_ends_in_recovery_then_abort_with_the_events():
    """The only doorway is closed: clear the costmap, rotate, back up, each logged, then ABORTED."""
    mapped = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 1.0), (2.9, 2.0, 3.1, 3.0)))  # a wall with a doorway
    world = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 3.0),))  # ... that someone has since closed
    sim = make_sim(world, mapped, Pose2D(1.0, 1.5, 0.0))
    t, status, text = drive(sim, Pose2D(5.0, 1.5, 0.0))
    assert status == GoalStatus.ABORTED
    assert text == "no path round the obstacles the map does not show (after 3 recovery attempts)"
    recoveries = sim.events.of_type("recovery")
    assert [r["behaviour"] for r in recoveries] == ["clear_costmap", "rotate", "back_up"]
    assert [r["attempt"] for r in recoveries] == [1, 2, 3]
    assert all(r["reason"] == "no path round the obstacles the map does not show" for r in recoveries)
    assert recoveries[0]["cleared"] > 0
    assert recoveries[2]["distance"] == pytest.approx(0.3)
    assert sim.collisions == 0
    assert sim.robot.x < 2.9 - RADIUS
    # The clear kept what the laser still sees (the closed doorway), so the plan after it went round the wall's
    # marks and failed at once, instead of driving back into the wall the map does not show.
    assert recoveries[0]["kept"] > 0
    kinds = [e["type"] for e in sim.events.events if e["type"] in ("plan", "recovery", "path_blocked")]
    first_recovery = kinds.index("recovery")
    assert kinds[first_recovery + 1:first_recovery + 3] == ["plan", "recovery"]
    assert sim.events.events[-1]["type"] == "goal_result"
    # Clear, plan, see the wall again, a full turn, a 0.3 m back-up: about 11 s, far from any time limit.
    assert t < 20.0


def test_recovery_skips_what_cannot_help():
    """An empty costmap is not cleared, and a robot with its back to a wall does not back up."""
    closed = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 3.0),))  # the map itself has no way through
    start = Pose2D(RES + RADIUS + 0.02, 1.5, 0.0)  # 2 cm from the west wall, facing east
    sim = make_sim(closed, closed, start)
    _, status, text = drive(sim, Pose2D(5.0, 1.5, 0.0))
    assert status == GoalStatus.ABORTED
    assert text == "no path: the goal lies in a region the start cannot reach (after 1 recovery attempts)"
    assert [r["behaviour"] for r in sim.events.of_type("recovery")] == ["rotate"]
    assert len(sim.move_base.costmap) == 0  # the closed wall is on the map: nothing to mark
    assert sim.collisions == 0


# -- a bounded time without progress, at any time step -----------------------------------------------------
@pytest.mark.parametrize("dt", [0.05, 0.1, 0.3, 1.0])
def test_no_progress_is_aborted_within_the_bound_at_any_dt(dt):
    """A blind robot pressed against a wall the map does not have: no progress, ever."""
    mapped = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 1.0), (2.9, 2.0, 3.1, 3.0)))
    world = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 3.0),))
    sim = make_sim(world, mapped, Pose2D(2.9 - RADIUS - 0.02, 1.5, 0.0), laser=False, dt=dt)
    params = sim.move_base.params
    t, status, text = drive(sim, Pose2D(5.0, 1.5, 0.0), limit=600.0)
    assert (status, text) == (GoalStatus.ABORTED, "no progress for 10 s (after 2 recovery attempts)")
    assert [r["behaviour"] for r in sim.events.of_type("recovery")] == ["rotate", "back_up"]
    # Three spells of 10 s without progress, a full turn, a 0.3 m back-up: 30 s at least, and the bound.
    assert 3 * params.stuck_timeout + 2 * math.pi / params.recovery_speed <= t <= params.no_progress_bound(dt)
    assert params.no_progress_bound(1.0) < 60.0


def test_a_controller_circling_its_goal_is_aborted_within_the_bound(monkeypatch):
    """At dt 1.0 a follower that ignores the time step overshoots and circles: it moves, but makes no
    progress, and move_base gives up (this used to go on for two simulated hours)."""
    command = PathFollower.command
    monkeypatch.setattr(PathFollower, "command", lambda self, pose, dt=None: command(self, pose))
    follower = FollowerParams(xy_tolerance=0.05)
    sim = make_sim(EMPTY, EMPTY, Pose2D(1.0, 1.0, 0.0), dt=1.0, follower=follower)
    goal = Pose2D(3.5, 2.5, 1.0)
    t, status, text = drive(sim, goal, limit=600.0)
    assert status == GoalStatus.ABORTED and text.startswith("no progress for 10 s")
    params = sim.move_base.params
    last_progress = sim.events.of_type("recovery")[0]["t"] - params.stuck_timeout
    assert t - last_progress <= params.no_progress_bound(1.0)
    assert sim.distance > 1.5 * Pose2D(1.0, 1.0).distance_to(goal)  # it kept moving all the while
    monkeypatch.undo()
    sim = make_sim(EMPTY, EMPTY, Pose2D(1.0, 1.0, 0.0), dt=1.0, follower=follower)
    t, status, _ = drive(sim, goal)
    assert status == GoalStatus.SUCCEEDED and t <= 15.0  # the follower that knows the step settles on it
    assert sim.robot.pose.distance_to(goal) <= 0.05


@pytest.mark.parametrize("dt", [1.0, 0.5])
def test_a_patrol_lap_at_coarse_time_steps(make_patrol, b5203_poses, dt):
    machine = make_patrol(list(b5203_poses.goals), max_laps=1, dt=dt)
    machine.sim.move_base.use_laser(machine.sim.scan, machine.sim.config.laser)
    summary = run_patrol(machine, handle_sigint=False)
    assert (summary.laps, summary.goals_reached, summary.goals_aborted, summary.collisions) == (1, 15, 0, 0)
    assert summary.sim_time < 120.0  # the lap takes 42 s at dt 0.1


def test_a_known_world_leaves_the_costmap_empty_and_the_laser_mostly_idle(make_patrol, b5203_poses):
    """Returns from the map's own walls are not marked, even with range noise; scans are sparse."""
    machine = make_patrol(list(b5203_poses.goals), max_laps=1, laser=LaserParams(noise=0.02))
    sim = machine.sim
    sim.move_base.use_laser(sim.scan, sim.config.laser)
    summary = run_patrol(machine, handle_sigint=False)
    assert (summary.goals_reached, summary.collisions) == (15, 0)
    costmap = sim.move_base.costmap
    assert costmap.version == 0 and costmap.empty
    assert not sim.events.of_type("path_blocked")
    assert 10 <= costmap.scans <= sim.clock.steps / 10  # about one scan a metre or a turn of 50 degrees


# -- the costmap itself ----------------------------------------------------------------------------------
def test_costmap_marks_only_what_the_map_lacks_and_clears_what_the_laser_sees_through():
    box = (2.0, 1.8, 2.4, 2.2)
    world, mapped = ObstacleField(room(5.0, 4.0, boxes=(box,))), ObstacleField(room(5.0, 4.0))
    pose = Pose2D(1.0, 2.0, 0.0)
    costmap = LocalCostmap(mapped)
    assert costmap.update(pose, cast_scan(world, pose))
    pts = costmap.points()
    assert len(pts) == len(costmap) == 8  # the box's west face: 8 cells of 5 cm
    np.testing.assert_allclose(pts[:, 0], 2.025)
    assert pts[:, 1].min() == pytest.approx(1.825) and pts[:, 1].max() == pytest.approx(2.175)
    version = costmap.version
    assert not costmap.update(pose, cast_scan(world, pose))  # the same view changes nothing
    assert costmap.version == version
    # Planning sees the marks as obstacles.
    extended = costmap.as_map()
    assert extended.value_at(2.025, 2.0) == OCCUPIED and extended.value_at(1.5, 2.0) == FREE
    # The way through the box is blocked within reach; a path beside it is not.
    hit = costmap.blocking(np.array([[1.0, 2.0], [4.0, 2.0]]), RADIUS + 0.05)
    assert hit is not None and hit[0] == pytest.approx(2.0 - (RADIUS + 0.05), abs=RES) and hit[1] == 2.0
    assert costmap.blocking(np.array([[1.0, 2.0], [4.0, 2.0]]), RADIUS + 0.05, reach=0.5) is None
    assert costmap.blocking(np.array([[1.0, 3.0], [4.0, 3.0]]), RADIUS + 0.05) is None
    assert not costmap.disc_free(1.9, 2.0, RADIUS) and costmap.disc_free(1.7, 2.0, RADIUS)
    # The box is taken away: the next scan passes through its cells and clears them.
    assert costmap.update(pose, cast_scan(mapped, pose))
    assert costmap.empty and costmap.version == version + 1
    # Marks the beams never pass (behind the robot) are kept; clearing the costmap drops them.
    costmap.update(pose, cast_scan(world, pose))
    behind = Pose2D(3.5, 2.0, 0.0)
    costmap.update(behind, cast_scan(mapped, behind))
    assert len(costmap) == 8
    assert costmap.clear() == 8 and costmap.empty and costmap.clear() == 0


def test_returns_near_the_maps_walls_are_the_maps_own():
    """A pose error of a few centimetres shifts every wall return; none of them may be marked."""
    field = ObstacleField(room(5.0, 4.0))
    true_pose = Pose2D(1.0, 2.0, 0.3)
    scan = cast_scan(field, true_pose)
    costmap = LocalCostmap(field)
    believed = Pose2D(1.06, 1.95, 0.31)  # 8 cm and 0.01 rad off
    costmap.update(believed, scan)
    assert costmap.empty


def test_move_base_parameters_are_checked_and_the_bound_follows_them():
    with pytest.raises(ValueError, match="unknown recovery behaviour"):
        MoveBaseParams(recovery_behaviours=("clear_costmap", "dance"))
    assert MoveBaseParams().recovery_behaviours == RECOVERY_BEHAVIOURS == ("clear_costmap", "rotate", "back_up")
    only_turn = MoveBaseParams(recovery_behaviours=("rotate",))
    assert only_turn.no_progress_bound(0.1) == pytest.approx(2 * 10.1 + 2 * math.pi + 0.1)
    assert MoveBaseParams().no_progress_bound(0.1) == pytest.approx(4 * 10.1 + 2 * math.pi + 0.1 + 3.0 + 2.0 + 0.1)


def test_the_costmap_asks_the_laser_for_a_quarter_of_its_beams_and_half_its_range():
    sim = make_sim(EMPTY, EMPTY, Pose2D(1.0, 2.0, 0.0), laser=False)
    asked: list[LaserParams] = []

    def scan(laser: LaserParams) -> LaserScan:
        asked.append(laser)
        return sim.scan(laser)

    sim.move_base.use_laser(scan, sim.config.laser)
    _, status, _ = drive(sim, Pose2D(4.0, 2.0, 0.0))
    assert status == GoalStatus.SUCCEEDED
    assert asked and {(laser.beams, laser.fov, laser.range_max) for laser in asked} == {
        (160, sim.config.laser.fov, 3.0)}
