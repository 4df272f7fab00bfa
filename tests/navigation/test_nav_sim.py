"""The simulator's parts: base, collisions, laser, odometry, move_base, docking, clock and events."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from navigation.clock import SimClock
from navigation.costmap import ObstacleField
from navigation.docking import DockingStation
from navigation.events import EventLog
from navigation.geometry import Pose2D, wrap_angle
from navigation.maps import FREE, OCCUPIED, OccupancyMap
from navigation.move_base import GoalStatus
from navigation.planner import Planner
from navigation.robot import DiffDriveRobot, Odometry
from navigation.simulation import SimConfig, Simulation, StartPoseError

RES = 0.05


def room(width: float = 5.0, height: float = 4.0, boxes: tuple[tuple[float, float, float, float], ...] = ()
         ) -> OccupancyMap:
    """A walled room: free inside, one-cell walls on the border, optional occupied boxes (x0, y0, x1, y1)."""
    w, h = round(width / RES), round(height / RES)
    data = np.full((h, w), FREE, np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = OCCUPIED
    for x0, y0, x1, y1 in boxes:
        data[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = OCCUPIED
    return OccupancyMap(data, RES, Pose2D(0.0, 0.0, 0.0))


def test_base_ramps_within_acceleration_limits():
    robot = DiffDriveRobot(Pose2D(0, 0, 0))
    speeds = []
    for _ in range(7):
        robot.accept(*robot.propose(0.5, 1.0, 0.1))
        speeds.append((round(robot.v, 6), round(robot.w, 6)))
    assert speeds[:3] == [(0.1, 0.2), (0.2, 0.4), (0.3, 0.6)]
    assert speeds[-1] == (0.5, 1.0)
    robot.accept(*robot.propose(5.0, 9.0, 0.1))
    assert robot.v <= 0.5 and robot.w <= 1.9


def test_arc_integration_is_exact_for_a_full_circle():
    robot = DiffDriveRobot(Pose2D(0, 0, 0))
    robot.v, robot.w = 0.5, 0.5  # radius 1 m, a full turn takes 4*pi s
    for _ in range(round(4 * math.pi / 0.01)):
        robot.accept(*robot.propose(0.5, 0.5, 0.01))
    assert math.hypot(robot.x, robot.y) < 0.01


def test_driving_into_a_wall_stops_and_counts_one_collision():
    sim = Simulation(room(), Pose2D(1.0, 2.0, 0.0))
    sim.teleop = (0.5, 0.0)
    sim.run_for(15.0)
    wall_face = 5.0 - RES
    assert sim.collisions == 1
    assert wall_face - 0.18 - 0.06 < sim.robot.x <= wall_face - 0.18
    assert sim.robot.v == 0.0
    assert len(sim.events.of_type("collision")) == 1
    sim.teleop = (-0.3, 0.0)  # back off, then bump again: a second collision
    sim.run_for(2.0)
    assert not sim.in_contact
    sim.teleop = (0.5, 0.0)
    sim.run_for(3.0)
    assert sim.collisions == 2


def test_rotating_against_a_wall_is_not_a_collision():
    sim = Simulation(room(), Pose2D(5.0 - RES - 0.19, 2.0, 0.0))
    sim.teleop = (0.0, 1.0)
    sim.run_for(5.0)
    assert sim.collisions == 0
    assert sim.robot.w == pytest.approx(1.0)


def test_start_inside_an_obstacle_is_refused():
    with pytest.raises(StartPoseError, match=r"\(2\.500, 2\.000\).*inside an obstacle"):
        Simulation(room(boxes=((2.0, 1.5, 3.0, 2.5),)), Pose2D(2.5, 2.0, 0.0))
    with pytest.raises(StartPoseError, match="off the map"):
        Simulation(room(), Pose2D(-3.0, 2.0, 0.0))


def test_laser_sees_the_wall_ahead():
    sim = Simulation(room(5.0, 8.0), Pose2D(1.0, 4.0, 0.0))  # tall enough that every beam meets the east wall
    scan = sim.scan()
    assert len(scan.ranges) == 640
    angles = scan.angles()
    assert angles[0] == pytest.approx(-math.radians(29)) and angles[-1] == pytest.approx(math.radians(29))
    expected = (5.0 - RES - 1.0) / np.cos(angles)  # the inner face of the east wall
    assert np.all(np.abs(scan.ranges - expected) <= RES)
    far = Simulation(room(12.0, 4.0), Pose2D(1.0, 2.0, 0.0)).scan()
    assert np.isinf(far.ranges[320])  # 10.9 m away, beyond the 6 m range


def test_laser_follows_a_rotated_map_origin():
    data = np.zeros((80, 100), np.int8)
    data[:, -1] = OCCUPIED
    m = OccupancyMap(data, RES, Pose2D(1.0, 1.0, math.pi / 2))  # grid x axis points along world +y
    field = ObstacleField(m, unknown_is_obstacle=False)
    sim = Simulation(m, Pose2D(0.0, 2.0, math.pi / 2), field_=field)
    # The wall at grid column 99 lies at world y = 1 + 99 * 0.05 = 5.95; the robot looks along +y.
    assert sim.scan().ranges[320] == pytest.approx(5.95 - 2.0, abs=RES)


def test_odometry_without_noise_matches_the_true_motion():
    sim = Simulation(room(), Pose2D(1.0, 1.0, 0.3))
    sim.teleop = (0.3, 0.2)
    sim.run_for(5.0)
    start, now = Pose2D(1.0, 1.0, 0.3), sim.robot.pose
    dx, dy = now.x - start.x, now.y - start.y
    c, s = math.cos(-start.yaw), math.sin(-start.yaw)
    odom = sim.odom.pose
    assert (odom.x, odom.y) == pytest.approx((c * dx - s * dy, s * dx + c * dy), abs=1e-3)
    assert odom.yaw == pytest.approx(wrap_angle(now.yaw - start.yaw), abs=1e-6)
    assert sim.odom.distance == pytest.approx(sim.distance)
    assert sim.odometry_drift() < 1e-3


def test_odometry_noise_drifts_reproducibly():
    def drive(seed: int) -> Pose2D:
        sim = Simulation(room(), Pose2D(1.0, 1.0, 0.3),
                         SimConfig(odom_linear_noise=0.05, odom_angular_noise=0.05, seed=seed))
        sim.teleop = (0.3, 0.2)
        sim.run_for(5.0)
        return sim.odom.pose

    a, b, c = drive(1), drive(1), drive(2)
    assert a == b
    assert a != c
    noisy = Simulation(room(), Pose2D(1.0, 1.0, 0.3), SimConfig(odom_linear_noise=0.05, odom_angular_noise=0.05))
    noisy.teleop = (0.3, 0.2)
    noisy.run_for(5.0)
    assert 0.0 < noisy.odometry_drift() < 0.2
    odom = Odometry()
    odom.update(1.0, 0.0)
    assert odom.pose == Pose2D(1.0, 0.0, 0.0)


def test_goal_reached_within_tolerances_and_result_delivered_by_the_clock():
    sim = Simulation(room(), Pose2D(1.0, 1.0, 0.0))
    got: list[GoalStatus] = []
    goal = Pose2D(4.0, 3.0, 2.0)
    sim.move_base.send_goal(goal, lambda status, _text: got.append(status), name="g")
    assert got == []
    for _ in range(600):
        sim.step()
        if got:
            break
    assert got == [GoalStatus.SUCCEEDED]
    assert sim.robot.pose.distance_to(goal) <= 0.15
    assert abs(wrap_angle(sim.robot.yaw - goal.yaw)) <= 0.3
    assert sim.collisions == 0


def test_new_goal_preempts_the_old_and_cancel_preempts():
    sim = Simulation(room(), Pose2D(1.0, 1.0, 0.0))
    got: list[tuple[str, GoalStatus]] = []
    sim.move_base.send_goal(Pose2D(4.0, 3.0, 0.0), lambda s, _t: got.append(("a", s)))
    sim.run_for(1.0)
    sim.move_base.send_goal(Pose2D(4.0, 1.0, 0.0), lambda s, _t: got.append(("b", s)))
    sim.run_for(1.0)
    assert got == [("a", GoalStatus.PREEMPTED)]
    sim.move_base.cancel_goal()
    sim.run_for(0.2)
    assert got == [("a", GoalStatus.PREEMPTED), ("b", GoalStatus.PREEMPTED)]


def test_goal_off_the_map_is_aborted_at_once():
    sim = Simulation(room(), Pose2D(1.0, 1.0, 0.0))
    got: list[tuple[GoalStatus, str]] = []
    sim.move_base.send_goal(Pose2D(40.0, 1.0, 0.0), lambda s, t: got.append((s, t)))
    sim.step()
    assert got == [(GoalStatus.ABORTED, "goal is outside the map")]


def test_a_closed_doorway_is_seen_and_ends_in_recovery_then_abort_without_a_bump():
    """A wall the map still shows with a doorway: the laser's local costmap sees it closed, move_base stops short,
    runs its three recovery behaviours in order and gives up, never touching the wall."""
    mapped = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 1.0), (2.9, 2.0, 3.1, 3.0)))  # a wall with a doorway
    world = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 3.0),))  # ... that someone has since closed
    sim = Simulation(world, Pose2D(1.0, 1.5, 0.0), planner=Planner(ObstacleField(mapped)))
    got: list[tuple[GoalStatus, str]] = []
    sim.move_base.send_goal(Pose2D(5.0, 1.5, 0.0), lambda s, t: got.append((s, t)))
    sim.run_for(120.0)
    assert got == [(GoalStatus.ABORTED, "no path round the obstacles the map does not show (after 3 recovery "
                                        "attempts)")]
    assert [(r["attempt"], r["behaviour"]) for r in sim.events.of_type("recovery")] == [
        (1, "clear_costmap"), (2, "rotate"), (3, "back_up")]
    assert sim.collisions == 0
    assert sim.robot.x < 2.9 - 0.18  # stopped short of the wall


def test_without_its_laser_move_base_bumps_recovers_then_aborts():
    """The same room driven blind (no costmap): the bump stops the robot, and no progress ends the goal."""
    mapped = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 1.0), (2.9, 2.0, 3.1, 3.0)))
    world = room(6.0, 3.0, boxes=((2.9, 0.0, 3.1, 3.0),))
    sim = Simulation(world, Pose2D(1.0, 1.5, 0.0), planner=Planner(ObstacleField(mapped)))
    sim.move_base.scan_source = None
    got: list[tuple[GoalStatus, str]] = []
    sim.move_base.send_goal(Pose2D(5.0, 1.5, 0.0), lambda s, t: got.append((s, t)))
    sim.run_for(120.0)
    assert len(got) == 1
    status, text = got[0]
    assert status == GoalStatus.ABORTED
    assert text == "no progress for 10 s (after 2 recovery attempts)"
    assert [r["attempt"] for r in sim.events.of_type("recovery")] == [1, 2]
    assert sim.collisions >= 1
    assert sim.robot.x < 2.9


def test_dock_from_the_station_pose_charges():
    station = Pose2D(2.0, 2.0, 0.0)
    dock = DockingStation.in_front_of(station)
    assert (dock.pose.x, dock.pose.y) == pytest.approx((3.0, 2.0))
    assert abs(wrap_angle(dock.pose.yaw - math.pi)) < 1e-9
    sim = Simulation(room(), station, station=dock)
    got: list[GoalStatus] = []
    sim.start_dock(lambda s, _t: got.append(s))
    sim.run_for(12.0)
    assert got == [GoalStatus.SUCCEEDED]
    assert sim.robot.pose.distance_to(dock.docked_pose(0.18)) < 0.05
    assert sim.docked and sim.robot_battery.charging
    # (1.0 m - 0.18 m) at 0.1 m/s, after ramping up
    action_t = sim.events.of_type("action_result")[0]["t"]
    assert 8.2 <= action_t <= 9.0
    got.clear()
    sim.start_undock(lambda s, _t: got.append(s))
    sim.run_for(8.0)
    assert got == [GoalStatus.SUCCEEDED]
    assert not sim.robot_battery.charging
    # It drained a little on the way, so the dock topped it up before it left.
    assert [e["event"] for e in sim.events.of_type("robot_battery")] == [
        "PLUGGED_TO_DOCKBASE", "CHARGE_COMPLETED", "UNPLUGGED"]


@pytest.mark.parametrize(("start", "reason"), [
    (Pose2D(2.0, 2.0, math.pi), "faces 180 deg away"),
    (Pose2D(1.0, 2.0, 0.0), "2.00 m away"),
    (Pose2D(2.5, 1.2, 0.0), "deg off the dock's axis"),
])
def test_dock_fails_unless_close_in_front_and_facing(start, reason):
    dock = DockingStation.in_front_of(Pose2D(2.0, 2.0, 0.0))
    sim = Simulation(room(), start, station=dock)
    got: list[tuple[GoalStatus, str]] = []
    sim.start_dock(lambda s, t: got.append((s, t)))
    sim.run_for(25.0)
    assert len(got) == 1 and got[0][0] == GoalStatus.ABORTED
    assert reason in got[0][1]
    assert sim.events.of_type("action_result")[0]["t"] == pytest.approx(20.0, abs=0.11)
    assert not sim.robot_battery.charging


def test_clock_timers_fire_in_order_and_can_be_cancelled():
    clock = SimClock(0.1)
    fired: list[tuple[str, float]] = []
    clock.call_later(0.25, lambda: fired.append(("late", clock.now)))
    clock.call_later(0.1, lambda: fired.append(("soon", clock.now)))
    cancelled = clock.call_later(0.2, lambda: fired.append(("never", clock.now)))
    ticks = clock.every(0.2, lambda: fired.append(("tick", clock.now)))
    cancelled.cancel()
    for _ in range(5):
        clock.advance()
    ticks.cancel()
    for _ in range(5):
        clock.advance()
    assert [(n, round(t, 6)) for n, t in fired] == [("soon", 0.1), ("tick", 0.2), ("late", 0.3), ("tick", 0.4)]
    with pytest.raises(ValueError):
        SimClock(0.0)


def test_events_stream_as_json_lines(tmp_path):
    now = [0.0]
    log = EventLog(lambda: now[0])
    seen: list[str] = []
    unsubscribe = log.subscribe(lambda e: seen.append(e["type"]))
    log.open(tmp_path / "e.jsonl")
    log.emit("a", value=1)
    now[0] = 2.5
    unsubscribe()
    log.emit("b", text="x")
    log.close()
    lines = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    assert lines == [{"t": 0.0, "type": "a", "value": 1}, {"t": 2.5, "type": "b", "text": "x"}]
    assert seen == ["a"]
