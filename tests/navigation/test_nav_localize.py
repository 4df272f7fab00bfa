"""Localisation: the amcl-like particle filter, the pose move_base drives on, and what the run reports."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import navigation
from navigation.cli import main
from navigation.costmap import ObstacleField
from navigation.docking import DockingStation
from navigation.geometry import Pose2D, wrap_angle
from navigation.laser import LaserParams
from navigation.localization import (
    Amcl,
    AmclParams,
    ParticleFilter,
    compose,
    inverse,
    kld_sample_count,
)
from navigation.maps import FREE, OCCUPIED, OccupancyMap
from navigation.move_base import GoalStatus
from navigation.patrol import PatrolMachine
from navigation.planner import Planner
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation

DATA = Path(navigation.__file__).parent / "data"
RES = 0.05
NOISY = {"odom_linear_noise": 0.05, "odom_angular_noise": 0.05}


def lab(boxes: tuple[tuple[float, float, float, float], ...] = ((2.0, 2.5, 2.6, 3.0), (4.5, 0.8, 5.2, 1.3)),
        origin: Pose2D | None = None) -> OccupancyMap:
    """A walled 7 m x 4 m room with a few blocks (x0, y0, x1, y1) so that no two places look alike."""
    w, h = round(7.0 / RES), round(4.0 / RES)
    data = np.full((h, w), FREE, np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = OCCUPIED
    for x0, y0, x1, y1 in boxes:
        data[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = OCCUPIED
    return OccupancyMap(data, RES, origin or Pose2D(0.0, 0.0, 0.0))


def loglik(pf: ParticleFilter, sim: Simulation, poses: list[Pose2D]) -> np.ndarray:
    scan = sim.scan(LaserParams(beams=30))
    ll, used = pf.log_likelihood(scan, np.array([p.x for p in poses]), np.array([p.y for p in poses]),
                                 np.array([p.yaw for p in poses]))
    assert used >= 20  # a few beams may see nothing within range; they are left out
    return ll


# -- the pieces ---------------------------------------------------------------------------------------

def test_exact_is_the_default_and_adds_nothing():
    sim = Simulation(lab(), Pose2D(1.0, 1.0, 0.0))
    assert sim.config.localization == "exact"
    assert sim.localizer is None
    sim.teleop = (0.3, 0.2)
    sim.run_for(3.0)
    assert sim.pose_estimate() == sim.robot.pose


def test_an_unknown_mode_is_refused():
    with pytest.raises(ValueError, match=r"unknown localization mode 'gps'.*exact, amcl, odometry"):
        Simulation(lab(), Pose2D(1.0, 1.0, 0.0), SimConfig(localization="gps"))


def test_the_scan_likelihood_peaks_at_the_true_pose_in_any_map_frame():
    results = []
    for origin in (Pose2D(0.0, 0.0, 0.0), Pose2D(1.0, -2.0, math.pi / 2)):
        truth = compose(origin, Pose2D(1.2, 1.5, 0.4))  # the same place in the room, whatever the map frame
        sim = Simulation(lab(origin=origin), truth)
        off = [compose(truth, Pose2D(dx, dy, dyaw)) for dx, dy, dyaw in
               ((0.1, 0, 0), (-0.1, 0, 0), (0, 0.1, 0), (0, -0.1, 0), (0, 0, 0.05), (0, 0, -0.05), (0.3, 0.3, 0.2))]
        ll = loglik(ParticleFilter(sim.field), sim, [truth, *off])
        assert np.all(ll[0] > ll[1:] + 0.5)  # 10 cm or 3 degrees off costs at least a factor 1.6
        results.append(ll)
    assert results[0] == pytest.approx(results[1], abs=1e-6)  # a rotated map origin changes nothing


def test_end_points_deep_inside_a_block_do_not_score_as_hits():
    # Facing the 0.6 m deep block from 1 m away: a pose 0.3 m closer puts every end point 0.3 m inside it.
    # A plain distance-to-obstacle table scores those as perfect hits; the surface distance does not.
    sim = Simulation(lab(), Pose2D(1.0, 2.75, 0.0))
    pf = ParticleFilter(sim.field, AmclParams(max_beams=30))
    scan = sim.scan(LaserParams(beams=30, fov=math.radians(20.0)))
    xs = np.array([1.0, 1.3])
    ll, _ = pf.log_likelihood(scan, xs, np.full(2, 2.75), np.zeros(2))
    assert ll[0] > ll[1] + 5.0


def test_pose_algebra():
    a, b = Pose2D(1.0, 2.0, 0.7), Pose2D(-0.3, 0.5, -2.0)
    back = compose(inverse(a), compose(a, b))
    assert (back.x, back.y, back.yaw) == pytest.approx((b.x, b.y, b.yaw))
    assert compose(a, inverse(a)).distance_to(Pose2D(0.0, 0.0)) < 1e-12


def test_motion_model_without_noise_moves_each_particle_by_the_odometry_step():
    pf = ParticleFilter(ObstacleField(lab()), AmclParams(odom_alpha1=0, odom_alpha2=0, odom_alpha3=0, odom_alpha4=0))
    pf.initialize(Pose2D(2.0, 2.0, 0.0), sigma_xy=0.3, sigma_yaw=1.0, count=50)
    before = [Pose2D(x, y, t) for x, y, t in zip(pf.x, pf.y, pf.yaw, strict=True)]
    old, new = Pose2D(0.5, -0.2, 0.3), Pose2D(1.1, 0.4, 1.2)
    pf.predict(old, new)
    step = compose(inverse(old), new)
    for p, x, y, t in zip(before, pf.x, pf.y, pf.yaw, strict=True):
        want = compose(p, step)
        assert (x, y) == pytest.approx((want.x, want.y), abs=1e-9)
        assert wrap_angle(t - want.yaw) == pytest.approx(0.0, abs=1e-9)


def test_motion_noise_grows_with_the_distance_driven_and_is_unbiased():
    pf = ParticleFilter(ObstacleField(lab()), rng=np.random.default_rng(3))
    spreads = []
    for distance in (0.2, 1.0):
        pf.initialize(Pose2D(0.0, 0.0, 0.0), sigma_xy=0.0, sigma_yaw=0.0, count=4000)
        pf.predict(Pose2D(0.0, 0.0, 0.0), Pose2D(distance, 0.0, 0.0))
        travelled = np.hypot(pf.x, pf.y)
        assert float(np.mean(travelled)) == pytest.approx(distance, rel=0.03)
        assert float(np.mean(pf.yaw)) == pytest.approx(0.0, abs=0.03)
        spreads.append(float(np.std(travelled)))
    # amcl's diff model: the distance's sigma is sqrt(alpha3) times the distance.
    assert spreads == pytest.approx([math.sqrt(AmclParams().odom_alpha3) * d for d in (0.2, 1.0)], rel=0.1)


def test_kld_bound_and_adaptive_particle_count():
    assert kld_sample_count(1, 0.01, 2.33) == 1
    # (k - 1) / (2 err) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z)^3 for k = 10 bins.
    assert kld_sample_count(10, 0.01, 2.33) == math.ceil(450 * (1 - 2 / 81 + math.sqrt(2 / 81) * 2.33) ** 3)
    assert kld_sample_count(20, 0.01, 2.33) > kld_sample_count(10, 0.01, 2.33)
    p = AmclParams(min_particles=100, max_particles=3000)
    pf = ParticleFilter(ObstacleField(lab()), p)
    pf.initialize(Pose2D(3.2, 2.2, 0.09), sigma_xy=0.02, sigma_yaw=0.01, count=3000)
    pf.resample()
    assert pf.count == p.min_particles  # all in one histogram bin: the floor
    pf.initialize(Pose2D(3.0, 2.0, 0.09), sigma_xy=0.02, sigma_yaw=0.01, count=3000)
    pf.resample()
    assert pf.count == kld_sample_count(4, p.kld_err, p.kld_z)  # on the corner of four bins
    pf.initialize(Pose2D(3.0, 2.0, 0.0), sigma_xy=1.0, sigma_yaw=1.0, count=3000)
    pf.resample()
    assert pf.count == p.max_particles  # spread over hundreds of bins: the ceiling
    assert pf.effective_count == pytest.approx(p.max_particles)


def test_filter_converges_from_a_wrong_initial_pose_and_tracks():
    start = Pose2D(1.0, 1.2, 0.0)
    sim = Simulation(lab(), start, SimConfig(localization="amcl", seed=4, **NOISY))
    amcl = sim.localizer
    assert isinstance(amcl, Amcl)
    # Told the robot is 0.32 m and 9 degrees off, with a wide spread, as an operator's guess would be.
    amcl.set_pose(compose(start, Pose2D(0.25, -0.2, 0.15)), sigma_xy=0.3, sigma_yaw=0.2)
    assert sim.pose_estimate().distance_to(start) > 0.25
    sim.step()  # the first scan is weighed at once
    assert sim.pose_estimate().distance_to(sim.robot.pose) < 0.1
    assert abs(wrap_angle(sim.pose_estimate().yaw - sim.robot.yaw)) < 0.05
    goal = Pose2D(5.8, 3.0, 1.5)
    got: list[GoalStatus] = []
    sim.move_base.send_goal(goal, lambda status, _text: got.append(status))
    sim.run_for(3.0)
    assert sim.pose_estimate().distance_to(sim.robot.pose) < 0.05
    errors = []
    while not got and sim.clock.now < 60.0:
        sim.step()
        errors.append(sim.pose_estimate().distance_to(sim.robot.pose))
    assert got == [GoalStatus.SUCCEEDED]
    assert max(errors) < 0.08
    assert sim.robot.pose.distance_to(goal) <= 0.15
    assert sim.collisions == 0


def test_cost_per_update_is_bounded():
    p = AmclParams(max_particles=800, max_beams=20)
    sim = Simulation(lab(), Pose2D(1.0, 1.2, 0.0), SimConfig(localization="amcl", amcl=p, **NOISY))
    amcl = sim.localizer
    assert isinstance(amcl, Amcl)
    asked: list[int] = []
    scan = sim.scan
    amcl._scan = lambda laser: asked.append(laser.beams) or scan(laser)
    sim.step()
    assert amcl.updates == 1  # the first scan is weighed at once
    sim.run_for(5.0)
    assert amcl.updates == 1  # standing still: no update, no cost
    sim.move_base.send_goal(Pose2D(5.8, 3.0, 1.5))
    counts = []
    for _ in range(300):
        sim.step()
        counts.append(amcl.particles)
        assert amcl.beams_used <= p.max_beams
    assert set(asked) == {20}  # the simulated laser casts only the beams the filter reads
    assert max(counts) <= p.max_particles and min(counts) >= p.min_particles
    # Updates come every update_min_d metres or update_min_a radians, not every step.
    assert 5 < amcl.updates - 1 < 300 / 2


def test_runs_are_reproducible_with_a_seed():
    def run(seed: int) -> Pose2D:
        sim = Simulation(lab(), Pose2D(1.0, 1.2, 0.0), SimConfig(localization="amcl", seed=seed, **NOISY))
        sim.move_base.send_goal(Pose2D(5.8, 3.0, 1.5))
        sim.run_for(6.0)
        return sim.pose_estimate()

    assert run(1) == run(1)
    assert run(1) != run(2)


def test_an_obstacle_missing_from_the_map_does_not_mislead_the_filter():
    # The world has a box the map does not: the laser sees it, the filter must not be pulled by it.
    known = lab()
    world = lab(boxes=((2.0, 2.5, 2.6, 3.0), (4.5, 0.8, 5.2, 1.3), (3.2, 1.9, 3.6, 2.3)))
    cfg = SimConfig(localization="amcl", seed=2, **NOISY)
    planner = Planner(ObstacleField(known))
    sim = Simulation(world, Pose2D(1.0, 1.2, 0.3), cfg, field_=ObstacleField(world), planner=planner)
    assert sim.localizer is not None and isinstance(sim.localizer, Amcl)
    assert sim.localizer.filter.field is planner.field
    sim.teleop = (0.3, 0.0)
    errors = []
    for _ in range(60):  # 1.8 m towards the unmapped box, which fills much of the view
        sim.step()
        errors.append(sim.pose_estimate().distance_to(sim.robot.pose))
    assert sim.collisions == 0
    assert max(errors) < 0.1


# -- whole patrols ------------------------------------------------------------------------------------

def patrol(b5203_map, b5203_poses, localization: str, laps: int = 3, seed: int = 0):
    cfg = SimConfig(record_every=0, localization=localization, seed=seed, **NOISY)
    station = b5203_poses.station
    sim = Simulation(b5203_map, station, cfg, station=DockingStation.in_front_of(station))
    sim.events.keep = True
    sent: dict[int, Pose2D] = {}
    arrivals: list[tuple[str, float, float]] = []

    def on_event(e: dict) -> None:
        if e["type"] == "goal_sent":
            sent[e["goal_id"]] = Pose2D(e["x"], e["y"], e["yaw"])
        elif e["type"] == "goal_result":
            goal, truth = sent[e["goal_id"]], sim.robot.pose  # where the robot really is when it says so
            arrivals.append((e["status"], truth.distance_to(goal), abs(wrap_angle(truth.yaw - goal.yaw))))

    sim.events.subscribe(on_event)
    summary = run_patrol(PatrolMachine(sim, list(b5203_poses.goals), station, max_laps=laps), handle_sigint=False)
    return sim, summary, arrivals


def test_goals_are_reached_with_5_percent_odometry_noise_thanks_to_amcl(b5203_map, b5203_poses):
    sim, summary, arrivals = patrol(b5203_map, b5203_poses, "amcl")
    n = 3 * len(b5203_poses.goals)
    assert (summary.goals_reached, summary.goals_aborted, summary.collisions) == (n, 0, 0)
    # Every goal is reached within move_base's tolerances measured on the TRUE pose.
    assert [a[0] for a in arrivals] == ["SUCCEEDED"] * n
    assert max(a[1] for a in arrivals) <= 0.15
    assert max(a[2] for a in arrivals) <= 0.3
    # The estimate stays within 0.1 m of the truth at every step.
    assert summary.localization == "amcl"
    assert summary.localization_error_max < 0.1
    assert summary.localization_error_mean < 0.04
    assert summary.as_dict()["localization_error_max_m"] == round(summary.localization_error_max, 3)
    # ... while the wheels alone drifted more than the goal tolerance.
    assert summary.odometry_drift > 0.15
    # The error is in the event log at every goal result.
    events = sim.events.events
    at_goals = [events[i + 1] for i, e in enumerate(events) if e["type"] == "goal_result"]
    assert all(e["type"] == "localization" and e["cause"] == "goal_result" for e in at_goals)
    assert max(e["error"] for e in at_goals) < 0.1
    periodic = [e for e in events if e["type"] == "localization" and e["cause"] == "period"]
    assert len(periodic) >= summary.sim_time // 10
    assert {"x", "y", "yaw", "error", "yaw_error", "particles", "updates"} <= set(periodic[-1])


def test_without_localization_the_same_noise_misses_goals(b5203_map, b5203_poses):
    # Four laps: the drift grows with the distance driven (three laps left it at 0.298 m once the controller
    # slowed near obstacles, four at 0.42 m).
    _sim, summary, arrivals = patrol(b5203_map, b5203_poses, "odometry", laps=4)
    assert summary.localization == "odometry"
    assert summary.localization_error_max > 0.3
    missed = [a for a in arrivals if a[0] != "SUCCEEDED" or a[1] > 0.15]
    assert len(missed) > len(arrivals) // 2


# -- the command --------------------------------------------------------------------------------------

def test_command_option_summary_and_events(tmp_path, capsys):
    events = tmp_path / "e.jsonl"
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--laps", "1", "--odom-noise", "0.05",
                 "--localization", "amcl", "--events", str(events)])
    out, err = capsys.readouterr()
    assert code == 0 and err == ""
    fields = {k.strip(): v.strip() for k, v in (line.split(":", 1) for line in out.strip().splitlines())}
    assert fields["goals"] == "15 reached, 0 aborted, 0 preempted"
    text = fields["localization"]
    assert text.startswith("amcl: estimate off by ") and text.endswith(" filter updates")
    mean, worst = (float(w) for w in text.split() if w.replace(".", "").isdigit() and "." in w)
    assert 0.0 < mean < worst < 0.1
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    loc = [e for e in lines if e["type"] == "localization"]
    assert sum(e["cause"] == "goal_result" for e in loc) == 15
    assert all(e["mode"] == "amcl" and e["error"] < 0.1 for e in loc)


def test_command_default_and_refused_mode(capsys):
    code = main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--time-limit", "5"])
    out, _ = capsys.readouterr()
    assert code == 0
    assert "localization:   exact (navigation sees the true pose)" in out
    with pytest.raises(SystemExit) as exc:
        main([str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"), "--localization", "gps"])
    assert exc.value.code == 2
    assert "invalid choice: 'gps'" in capsys.readouterr().err
