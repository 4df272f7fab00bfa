"""A robot waiting for a person to move on keeps only the marks it sees: marks out of the laser's view are a
walker's trail (where someone was), and a wait for a way round them waits for nobody. Simulated time only."""

from __future__ import annotations

import math

import numpy as np

from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.laser import LaserScan
from navigation.local_costmap import LocalCostmap
from navigation.move_base import PATIENT_RECOVERY_BEHAVIOURS, GoalStatus, MoveBaseParams
from navigation.people_scenarios import WALKER_RADIUS, corridor_map
from navigation.simulation import SimConfig, Simulation
from navigation.world import World, WorldObject

FOV = math.radians(58.0)


def one_return(at: float, beams: int = 59) -> LaserScan:
    """A 58 degree scan whose middle beam ends ``at`` metres ahead; every other beam sees nothing in range."""
    ranges = np.full(beams, np.inf)
    ranges[beams // 2] = at
    return LaserScan(-FOV / 2.0, FOV / (beams - 1), ranges, 0.05, 3.0)


def marked_near(costmap: LocalCostmap, x: float, y: float) -> bool:
    return len(costmap.near(x, y, 0.06)) > 0


def test_refresh_keeps_what_is_in_view_and_beside_the_robot_and_forgets_the_trail_farther_off():
    costmap = LocalCostmap(ObstacleField(corridor_map(10.0, 4.0)))
    assert costmap.params.keep_near == 1.0
    robot = Pose2D(5.0, 2.0, 0.0)
    costmap.update(Pose2D(5.0, 2.0, math.pi), one_return(1.5))  # seen earlier, looking back: a mark at (3.5, 2)
    costmap.update(Pose2D(5.0, 2.0, -math.pi / 2), one_return(0.6))  # and beside the robot: a mark at (5, 1.4)
    costmap.update(robot, one_return(1.0))  # now looking ahead: a mark at (6, 2)
    for x, y in ((3.5, 2.0), (5.0, 1.4), (6.0, 2.0)):
        assert marked_near(costmap, x, y)  # update keeps what it cannot see
    version = costmap.version
    assert costmap.refresh(robot, one_return(1.0))
    assert not marked_near(costmap, 3.5, 2.0)  # the trail, 1.5 m off and out of view, is forgotten
    assert marked_near(costmap, 5.0, 1.4) and marked_near(costmap, 6.0, 2.0)  # beside (0.6 m) and in view stay
    assert (costmap.last_marked, costmap.last_cleared, costmap.version) == (0, 1, version + 1)
    # The same view again changes nothing: the version stays, so nobody plans again for it.
    assert not costmap.refresh(robot, one_return(1.0)) and costmap.version == version + 1
    # What a beam passes through goes, near or not: the person beside has gone when the laser sees past them.
    assert costmap.refresh(Pose2D(5.0, 2.0, -math.pi / 2), one_return(2.0))
    assert not marked_near(costmap, 5.0, 1.4)


def waiting_robot(order: tuple[str, ...]) -> tuple[Simulation, float]:
    """A person stands for good in the middle of a 1.2 m corridor (too narrow to pass); the robot drives up to it
    and recovers. Returns the simulation stepped until 3 s into the wait (or the abort) and when the wait began."""
    person = WorldObject("person", "cylinder", 5.0, 0.6, radius=WALKER_RADIUS, height=1.7)
    config = SimConfig(move_base=MoveBaseParams(recovery_behaviours=order))
    sim = Simulation(corridor_map(10.0, 1.2), Pose2D(1.0, 0.6, 0.0), config, world=World(obstacles=(person,)))
    got: list[tuple[GoalStatus, str]] = []
    sim.move_base.send_goal(Pose2D(8.0, 0.6, 0.0), lambda status, text: got.append((status, text)))
    while not got and sim.move_base.recovering != "wait" and sim.clock.now < 60.0:
        sim.step()
    began = sim.clock.now
    while not got and sim.clock.now < began + 3.0:
        sim.step()
    return sim, began


def test_a_waiting_robot_forgets_a_trail_out_of_its_view_but_not_the_person_in_front():
    sim, began = waiting_robot(PATIENT_RECOVERY_BEHAVIOURS)
    mb = sim.move_base
    assert mb.recovering == "wait" and began < 20.0
    # A walker went past behind the robot a moment ago: its trail, 1.5 m behind, out of the laser's view.
    robot = sim.robot.pose
    behind = robot.ahead(-1.5)
    mb.costmap.update(Pose2D(robot.x, robot.y, robot.yaw + math.pi), one_return(1.5))
    assert marked_near(mb.costmap, behind.x, behind.y)
    for _ in range(10):  # one second: at least one scan at the watching rate (every 0.75 s)
        sim.step()
    assert mb.recovering == "wait"
    assert not marked_near(mb.costmap, behind.x, behind.y)
    # The person still stands in view and stays marked: the wait goes on, and nothing was touched.
    assert len(mb.costmap.near(5.0, 0.6, WALKER_RADIUS + 0.1)) > 0
    assert sim.collisions == 0



def test_subset_is_a_new_layer_with_only_the_chosen_marks():
    costmap = LocalCostmap(ObstacleField(corridor_map(10.0, 4.0)))
    costmap.update(Pose2D(5.0, 2.0, math.pi), one_return(1.5))
    costmap.update(Pose2D(5.0, 2.0, 0.0), one_return(1.0))
    pts = costmap.points()
    ahead = pts[:, 0] > 5.0
    part = costmap.subset(ahead)
    assert len(part) == int(ahead.sum()) == 1 and len(costmap) == 2  # the layer itself is untouched
    assert marked_near(part, 6.0, 2.0) and not marked_near(part, 3.5, 2.0)
