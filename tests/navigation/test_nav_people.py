"""People who are solid: walkers never pass through the robot, every overlap is a counted collision, and the
controller neither drives into a walker nor forgets one still standing in view.

All in simulated time: a run is deterministic per seed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from navigation.costmap import ObstacleField
from navigation.geometry import Pose2D
from navigation.laser import LaserParams, cast_scan
from navigation.local_costmap import LocalCostmap
from navigation.maps import load_map
from navigation.move_base import GoalStatus
from navigation.people_scenarios import WALKER_RADIUS, corridor_map, drive_goals, find_corridor, walker
from navigation.simulation import SimConfig, Simulation
from navigation.walkers import GAP, PATIENCE
from navigation.world import World, WorldObject, parse_world

RADIUS = SimConfig().robot.radius
CONTACT = RADIUS + WALKER_RADIUS  # centres closer than this: the bodies overlap
WILLOW = "maps/willow_2010/willow-2010-02-18-0.10.yaml"


def walker_distances(sim: Simulation, steps: int) -> list[float]:
    """Step ``steps`` times; the distance between the robot's and the (first) walker's centres after each."""
    out = []
    body = sim.world.obstacles[0]
    for _ in range(steps):
        sim.step()
        x, y = body.position_at(sim.clock.now)
        out.append(math.hypot(x - sim.robot.x, y - sim.robot.y))
    return out


# -- the world file and the live copy --------------------------------------------------------------------
def test_world_file_declares_how_a_walker_avoids_and_rejects_unknown_modes():
    text = """obstacles:
  - {name: p1, shape: cylinder, radius: 0.25, height: 1.7, path: [[1, 1], [4, 1]], speed: 0.4}
  - {name: p2, shape: cylinder, radius: 0.25, height: 1.7, path: [[1, 2], [4, 2]], speed: 0.4, avoid: sidestep}
"""
    world = parse_world(text, "people.world.yaml")
    assert [o.avoid for o in world.obstacles] == ["stop", "sidestep"]
    with pytest.raises(Exception, match=r"people\.world\.yaml.*avoid.*wander") as err:
        parse_world(text.replace("sidestep", "wander"), "people.world.yaml")
    assert len(str(err.value).splitlines()) <= 3


def test_a_simulation_steps_its_own_copy_of_the_walkers():
    world = World(obstacles=(walker("p", (1.0, 1.0), (9.0, 1.0), 0.5),))
    sim = Simulation(corridor_map(10.0, 2.0), Pose2D(5.0, 1.6, 0.0), world=world)
    sim.run_for(4.0)
    # The world given stays scripted; the simulation's live copy went where the crowd moved it.
    assert world.obstacles[0].track is None and world.obstacles[0].position_at(4.0) == pytest.approx((3.0, 1.0))
    assert sim.world.obstacles[0].position_at(sim.clock.now) == pytest.approx((3.0, 1.0), abs=0.06)
    assert sim.world.obstacles[0].position_at(2.0) == pytest.approx((2.0, 1.0), abs=0.06)


# -- bodies: a walker meets a stopped robot in a corridor -------------------------------------------------
def test_blind_walker_through_a_stopped_robot_is_a_collision_every_time():
    """``avoid: none`` is the scripted walker of old: it walks through the robot, and each pass is counted."""
    world = World(obstacles=(walker("p", (1.0, 0.8), (9.0, 0.8), 0.4, avoid="none"),))
    sim = Simulation(corridor_map(10.0, 1.6), Pose2D(5.0, 0.8, 0.0), world=world)
    dist = walker_distances(sim, 600)
    assert min(dist) < 0.01  # it did walk through
    events = sim.events.of_type("collision")
    # Contact begins when the walker is 0.43 m short of the robot: 8.9 s, 28.9 s, 48.9 s.
    assert [round(e["t"], 1) for e in events] == [9.0, 29.0, 49.0]
    assert all(e["by"] == "obstacle" and e["obstacle"] == "p" for e in events)
    assert sim.collisions == 3 and len(sim.collision_points) == 3


def test_walker_stops_for_a_stopped_robot_then_turns_back():
    world = World(obstacles=(walker("p", (1.0, 0.8), (9.0, 0.8), 0.4),))
    sim = Simulation(corridor_map(10.0, 1.6), Pose2D(5.0, 0.8, 0.0), world=world)
    dist = walker_distances(sim, 600)
    assert min(dist) >= CONTACT + GAP
    assert sim.collisions == 0
    # It stops 0.6 m short (about 7.4 s in), gives up after PATIENCE seconds, walks back to its start and comes
    # again: three approaches in 60 s, each ending in a wait and a turn.
    assert sim.crowd.turns == 3
    assert sim.crowd.stops >= 3 * round(PATIENCE / sim.config.dt)


def test_sidestepping_walker_passes_beside_a_stopped_robot():
    world = World(obstacles=(walker("p", (1.0, 1.1), (9.0, 1.1), 0.4, avoid="sidestep"),))
    sim = Simulation(corridor_map(10.0, 2.2), Pose2D(5.0, 1.1, 0.0), world=world)
    dist = walker_distances(sim, 300)
    assert min(dist) >= CONTACT + GAP
    assert sim.collisions == 0 and sim.crowd.turns == 0 and sim.crowd.sidesteps > 0
    track = sim.world.obstacles[0].track
    assert max(track.xs) > 8.9  # it got past the robot to the far end: side-stepping, not stopping
    assert max(abs(y - 1.1) for y in track.ys) >= CONTACT + GAP - 0.05  # off its line by about a body width


def test_sidestepping_walker_without_room_stops_instead():
    world = World(obstacles=(walker("p", (1.0, 0.8), (9.0, 0.8), 0.4, avoid="sidestep"),))
    sim = Simulation(corridor_map(10.0, 1.6), Pose2D(5.0, 0.8, 0.0), world=world)
    dist = walker_distances(sim, 300)
    assert min(dist) >= CONTACT + GAP and sim.collisions == 0 and sim.crowd.turns >= 1


@pytest.mark.realdata
@pytest.mark.parametrize("localization", ["exact", "amcl"])
def test_walker_crossing_a_stopped_robot_in_a_willow_corridor_does_not_pass_through(shared_data, localization):
    occ_map = load_map(shared_data / WILLOW)
    field = ObstacleField(occ_map)
    corridor = find_corridor(field, half_length=5.0, max_half_width=1.0)
    assert corridor is not None
    a, b = corridor.point(-4.5), corridor.point(4.5)
    world = World(obstacles=(walker("p", a, b, 0.5),))
    start = Pose2D(*corridor.point(0.0), corridor.heading)
    sim = Simulation(occ_map, start, SimConfig(localization=localization, seed=3), field_=field, world=world)
    dist = walker_distances(sim, 400)
    assert min(dist) >= CONTACT + GAP
    assert sim.collisions == 0 and sim.crowd.turns >= 1
    if localization == "amcl":  # nothing passed through the robot, so nothing dragged the estimate off
        assert sim.localizer is not None and sim.localizer.errors.max < 0.3


# -- every overlap is counted ---------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_overlap_of_robot_and_walker_goes_uncounted(seed):
    """Blind walkers and a driving robot: every step the bodies overlap falls in a counted contact."""
    rng = np.random.default_rng(seed)
    walkers = tuple(walker(f"p{k}", (rng.uniform(1, 3), rng.uniform(0.6, 1.4)), (rng.uniform(8, 11), 1.0),
                           rng.uniform(0.3, 0.7), avoid="none") for k in range(3))
    sim = Simulation(corridor_map(12.0, 2.0), Pose2D(0.8, 1.0, 0.0), SimConfig(seed=seed),
                     world=World(obstacles=walkers))
    goals = [Pose2D(11.2, 1.0, 0.0), Pose2D(0.8, 1.0, math.pi)]
    k, episodes = 0, 0
    sim.move_base.send_goal(goals[0])
    for _ in range(3000):
        if not sim.move_base.active:
            k += 1
            sim.move_base.send_goal(goals[k % 2])
        before, was_in_contact = sim.collisions, sim.in_contact
        sim.step()
        now = sim.clock.now
        overlap = any(math.hypot(o.position_at(now)[0] - sim.robot.x, o.position_at(now)[1] - sim.robot.y)
                      < CONTACT - 1e-9 for o in sim.world.obstacles)
        if overlap:
            assert sim.in_contact, f"overlap at t={now:.1f} s not in a counted contact"
            if not was_in_contact:  # a new contact: counted in this very step
                episodes += 1
                assert sim.collisions == before + 1, f"overlap at t={now:.1f} s not counted"
    assert episodes >= 1  # the blind walkers did walk into the robot
    assert sim.collisions >= episodes
    assert sim.collisions == len(sim.events.of_type("collision")) == len(sim.collision_points)


# -- the controller -------------------------------------------------------------------------------------
def test_clear_costmap_keeps_what_the_scan_still_sees():
    occ_map = corridor_map(8.0, 4.0)
    field = ObstacleField(occ_map)
    world = World(obstacles=(WorldObject("box", "box", 3.0, 2.0, width=0.4, depth=0.4, height=0.5),))
    pose = Pose2D(1.0, 2.0, 0.0)
    laser = LaserParams(beams=160, range_max=3.0)
    scan = world.add_to_scan(cast_scan(field, pose, laser), pose, 0.0)
    costmap = LocalCostmap(field)
    costmap.update(pose, scan)
    seen = len(costmap)
    assert seen >= 5
    before = set(costmap.points().round(3).ravel().tolist())
    assert costmap.clear(pose, scan) == seen and len(costmap) == seen  # wiped, but still in view: marked again
    assert set(costmap.points().round(3).ravel().tolist()) == before
    gone = cast_scan(field, pose, laser)  # the box has been taken away
    assert costmap.clear(pose, gone) == seen and costmap.empty
    costmap.update(pose, scan)
    assert costmap.clear() == seen and costmap.empty  # no scan to go by: everything goes


def test_robot_passes_a_walker_coming_head_on_at_a_walk():
    world = World(obstacles=(walker("p", (9.0, 1.0), (1.0, 1.0), 0.4, avoid="sidestep"),))
    sim = Simulation(corridor_map(10.0, 2.0), Pose2D(1.0, 1.0, 0.0), world=world)
    got = []
    sim.move_base.send_goal(Pose2D(9.0, 1.0, 0.0), lambda s, t: got.append((s, t)))
    speeds_near = []
    body = sim.world.obstacles[0]
    last = (sim.robot.x, sim.robot.y)
    while not got and sim.clock.now < 200.0:
        sim.step()
        x, y = body.position_at(sim.clock.now)
        d = math.hypot(x - sim.robot.x, y - sim.robot.y) - CONTACT
        speed = math.hypot(sim.robot.x - last[0], sim.robot.y - last[1]) / sim.config.dt
        last = (sim.robot.x, sim.robot.y)
        if d < 0.3:
            speeds_near.append(speed)
    assert sim.collisions == 0
    # Within 0.3 m of the walker's body it slowed to a walk: at most 0.32 m/s (0.5 m/s elsewhere; the slowdown
    # zone's 0.2 m/s plus what one step of braking at 1 m/s^2 and the walker's own approach leave).
    assert speeds_near and max(speeds_near) <= 0.32
    assert sim.move_base.slowed > 0
    assert got == [(GoalStatus.SUCCEEDED, "goal reached")]


@pytest.mark.parametrize(("avoid", "localization"), [("stop", "exact"), ("sidestep", "amcl")])
def test_walkers_in_a_corridor_every_goal_reached_or_aborted_with_a_reason(avoid, localization):
    rng = np.random.default_rng(4)
    walkers = tuple(walker(f"p{k}", (rng.uniform(1, 4), 1.0 + rng.uniform(-0.3, 0.3)),
                           (rng.uniform(8, 11), 1.0 + rng.uniform(-0.3, 0.3)), rng.uniform(0.3, 0.6), avoid)
                    for k in range(2))
    sim = Simulation(corridor_map(12.0, 2.0, doors=2.5), Pose2D(0.8, 1.0, 0.0),
                     SimConfig(seed=4, localization=localization), world=World(obstacles=walkers))
    goals = [Pose2D(11.2, 1.0, 0.0) if k % 2 == 0 else Pose2D(0.8, 1.0, math.pi) for k in range(6)]
    results = drive_goals(sim, goals)
    assert all(s in (GoalStatus.SUCCEEDED, GoalStatus.ABORTED) and t for s, t in results)
    # Two walkers that stop in a 2 m corridor can leave no way round them: an abort then, with its reason.
    assert sum(s == GoalStatus.SUCCEEDED for s, _ in results) >= 4
    assert sim.collisions == 0
