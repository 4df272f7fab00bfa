"""objrec-patrol --rerun: the map, poses, path, scans, goals and state changes, read back with rerun's reader."""

from __future__ import annotations

import itertools
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pytest.importorskip("rerun")

import navigation  # noqa: E402
from navigation.cli import main  # noqa: E402
from navigation.geometry import Pose2D  # noqa: E402
from navigation.laser import LaserParams  # noqa: E402
from navigation.rerun_log import PatrolRecorder, open_patrol_rerun  # noqa: E402
from navigation.runner import run_patrol  # noqa: E402

from ..rrd_rows import read_recording  # noqa: E402

DATA = Path(navigation.__file__).parent / "data"
POSES = str(DATA / "b5203.txt")
MAP = str(DATA / "b5203.yaml")
SECOND = 1_000_000_000  # the sim_time timeline is in nanoseconds




def summary_fields(text: str) -> dict[str, str]:
    return {k.strip(): v.strip() for k, v in (line.split(":", 1) for line in text.strip().splitlines())}


def test_patrol_recording_holds_map_poses_scans_goals_and_states(tmp_path, capsys, b5203_map):
    assert main([POSES, "--map", MAP, "--time-limit", "30"]) == 0
    plain = summary_fields(capsys.readouterr().out)
    out = tmp_path / "patrol.rrd"
    assert main([POSES, "--map", MAP, "--time-limit", "30", "--rerun", str(out)]) == 0
    captured = capsys.readouterr()
    recorded = summary_fields(captured.out)
    assert captured.err == ""
    for field in ("outcome", "goals", "distance", "collisions", "robot battery"):
        assert recorded[field] == plain[field]  # recording changes nothing of the run
    assert recorded["goals"] == "7 reached, 0 aborted, 1 preempted"
    rows = read_recording(out)

    grid, = rows["/world/map"]
    fmt = grid["GridMap:format"][0]
    assert (fmt["width"], fmt["height"]) == (b5203_map.width, b5203_map.height)
    assert grid["GridMap:cell_size"] == [pytest.approx(0.05)]
    assert grid["GridMap:translation"].tolist() == [[0.0, 0.0, 0.0]]
    image = grid["GridMap:data"][0].reshape(b5203_map.height, b5203_map.width)
    assert np.array_equal(image, b5203_map.data[::-1].view(np.uint8))  # top row first, unknown 255
    assert {0, 100, 255} == set(np.unique(image).tolist())

    goals, = rows["/world/goals"]
    assert goals["Arrows3D:labels"] == [f"POSE_{i}" for i in range(15)]
    assert np.allclose(goals["Arrows3D:origins"][0][:2], [10.6897900314, 14.1520320024])
    assert rows["/world/station"][0]["Arrows3D:labels"] == ["station"]
    assert rows["/world/dock"][0]["Arrows3D:labels"] == ["dock"]

    # Poses every 0.2 s of the 30.1 s run, plus the start and the end; scans every second plus the start.
    poses = rows["/world/robot"]
    times = [r["sim_time"] for r in poses]
    assert len(poses) == 1 + 150 + 1
    assert times[0] == 0 and times[-1] == pytest.approx(30.1 * SECOND, abs=1e3) and times == sorted(times)
    start = poses[0]["Transform3D:translation"][0]
    assert np.allclose(start, [14.4, 12.8, 0.0])  # the station pose
    assert len(rows["/battery/robot"]) == len(rows["/battery/laptop"]) == len(poses)
    scans = rows["/world/robot/scan"]
    assert len(scans) == 31
    for scan in scans:
        points = scan["Points3D:positions"]
        assert 0 < len(points) <= 640
        bearings = np.arctan2(points[:, 1], points[:, 0])
        assert np.all(np.abs(bearings) <= math.radians(29.0) + 1e-6)  # in the robot's frame, 58 degrees wide
        assert np.all(np.hypot(points[:, 0], points[:, 1]) <= 6.0 + 1e-6)

    strip = rows["/world/path/0000"][-1]["LineStrips3D:strips"][0]
    assert np.allclose(strip[0][:2], [14.4, 12.8])
    assert np.allclose(strip[-1][:2], poses[-1]["Transform3D:translation"][0][:2], atol=0.051)
    driven = sum(math.dist(a, b) for a, b in itertools.pairwise(strip))
    assert driven == pytest.approx(float(recorded["distance"].split()[0]), abs=0.2)

    states = [r["TextLog:text"][0] for r in rows["/log/state"]]
    assert states[0] == "enter MONITORED_PATROL" and "enter SHUTDOWN" in states
    assert any(s.startswith("exit ") for s in states)
    events = [r["TextLog:text"][0] for r in rows["/log/events"]]
    sent = [e for e in events if e.startswith("goal_sent:")]
    assert len(sent) == 8 and "name=POSE_0" in sent[0]
    assert events[-1] == "outcome: outcome=shutdown"
    goal_labels = [r.get("Arrows3D:labels") for r in rows["/world/goal"] if r.get("Arrows3D:labels")]
    assert goal_labels[:3] == [["POSE_0"], ["POSE_1"], ["POSE_2"]]
    plans = [r for r in rows["/world/plan"] if r.get("LineStrips3D:strips")]
    assert len(plans) == 8  # one plan per goal sent


def test_recorder_leaves_a_noisy_run_unchanged(make_patrol, b5203_poses, tmp_path):
    """The recorder's scans draw noise from their own generator, never from the simulation's."""
    noisy = {"odom_linear_noise": 0.02, "odom_angular_noise": 0.02, "seed": 5,
             "laser": replace(LaserParams(), noise=0.02)}
    goals = list(b5203_poses.goals[:3])
    plain = make_patrol(goals, **noisy)
    run_patrol(plain, time_limit=20, handle_sigint=False)
    recorded = make_patrol(goals, **noisy)
    out = tmp_path / "noisy.rrd"
    with open_patrol_rerun(out, recorded.sim, goals, path_block=8) as recorder:
        assert isinstance(recorder, PatrolRecorder)
        run_patrol(recorded, time_limit=20, handle_sigint=False)
    assert recorded.sim.robot.pose == plain.sim.robot.pose
    assert recorded.sim.odom.pose == plain.sim.odom.pose

    rows = read_recording(out)
    final = rows["/world/robot"][-1]
    pose = recorded.sim.robot.pose
    assert np.allclose(final["Transform3D:translation"][0], [pose.x, pose.y, 0.0], atol=1e-5)
    assert final["sim_time"] == pytest.approx(recorded.sim.clock.now * SECOND, abs=1e3)
    # Full strips of 8 points hand over to the next, which starts where the last one ended.
    paths = sorted(p for p in rows if p.startswith("/world/path/"))
    assert len(paths) == recorder.path_strips >= 3
    strips = [rows[p][-1]["LineStrips3D:strips"][0] for p in paths]
    assert all(len(s) == 8 for s in strips[:-1])
    assert all(np.array_equal(a[-1], b[0]) for a, b in itertools.pairwise(strips))


def test_without_rerun_sdk_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "rerun", None)  # `import rerun` now raises ImportError
    out = tmp_path / "patrol.rrd"
    assert main([POSES, "--map", MAP, "--time-limit", "5", "--rerun", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.strip().splitlines() == [
        "objrec-patrol: error: --rerun needs rerun-sdk, which is not installed: install objrec[viz] "
        "(pip install 'objrec[viz]')"]
    assert not out.exists()


def test_a_target_that_is_not_rrd_is_refused(tmp_path, capsys):
    assert main([POSES, "--map", MAP, "--time-limit", "5", "--rerun", str(tmp_path / "patrol.txt")]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.strip().splitlines() == [
        f"objrec-patrol: error: --rerun {tmp_path / 'patrol.txt'}: give a file ending in .rrd, or spawn to open "
        "the viewer"]


def test_periods_must_be_positive(make_patrol, tmp_path):
    machine = make_patrol([Pose2D(12.0, 13.0)])
    with pytest.raises(ValueError, match="periods must be positive"):
        open_patrol_rerun(tmp_path / "x.rrd", machine.sim, pose_period=0.0)
    assert not (tmp_path / "x.rrd").exists()  # refused before anything was opened


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the display check is for Linux")
def test_spawn_without_a_display_is_refused(capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main([POSES, "--map", MAP, "--time-limit", "5", "--rerun", "spawn"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "--rerun spawn: no display" in lines[0] and "--rerun out.rrd" in lines[0]
