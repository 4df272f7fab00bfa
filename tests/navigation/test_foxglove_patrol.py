"""objrec-patrol --foxglove: a WebSocket client subscribes and decodes the map, the robot's pose, the goals,
the scan and the machine's state, as the server advertised them."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("foxglove")
pytest.importorskip("websockets")

import navigation
from foxgloveio.server import parse_address
from navigation.cli import main
from navigation.foxglove_log import MAP_FRAME, ROBOT_FRAME, open_patrol_view
from navigation.runner import run_patrol
from tests.foxglove_client import FoxgloveClient

DATA = Path(navigation.__file__).parent / "data"
POSES = str(DATA / "b5203.txt")
MAP = str(DATA / "b5203.yaml")
TOPICS = ["/map", "/robot/pose", "/tf", "/robot/scan", "/patrol/goals", "/patrol/state", "/patrol/labels",
          "/robot/path"]
#: A hang guard, never a timing assertion.
HANG_GUARD = 120


def grid_cells(grid: dict) -> np.ndarray:
    """The decoded Grid's cells as the structured array its advertised fields describe."""
    names = {f["name"]: f.get("offset", 0) for f in grid["fields"]}
    assert names == {"occupancy": 0, "red": 1, "green": 2, "blue": 3, "alpha": 4}
    layout = np.dtype([("occupancy", "i1"), ("red", "u1"), ("green", "u1"), ("blue", "u1"), ("alpha", "u1")])
    rows = len(grid["data"]) // grid["row_stride"]
    return np.frombuffer(grid["data"], dtype=layout).reshape(rows, grid["column_count"])


def yaw_of(orientation: dict) -> float:
    return 2.0 * math.atan2(orientation.get("z", 0.0), orientation.get("w", 0.0))


def test_patrol_view_serves_map_goals_pose_scan_and_state(make_patrol, b5203_map, b5203_poses):
    goals = b5203_poses.goals[:2]
    machine = make_patrol(goals, max_laps=1)
    sim = machine.sim
    view = open_patrol_view(parse_address("0"), sim, b5203_map, machine, goals, b5203_poses.station)
    try:
        with FoxgloveClient(view.server.url, TOPICS) as client:
            assert client.wait_for(lambda c: all(view.server.wanted(ch) for ch in (view.pose, view.scan, view.map)),
                                   HANG_GUARD), client.error
            summary = run_patrol(machine, time_limit=60)
            view.sample()  # the pose at the end: the newest message is never the one a full queue drops
            end = sim.robot.pose

            def at_the_end(c: FoxgloveClient) -> bool:  # the final sample arrived (the robot may turn in place)
                poses = c.messages("/robot/pose")
                if not poses:
                    return False
                last = poses[-1].message["pose"]
                return (last["position"]["x"] == pytest.approx(end.x) and last["position"]["y"] == pytest.approx(end.y)
                        and yaw_of(last["orientation"]) == pytest.approx(end.yaw, abs=1e-9))

            assert client.wait_for(lambda c: c.messages("/map") and c.messages("/patrol/goals")
                                   and c.messages("/patrol/state") and at_the_end(c), HANG_GUARD), client.error
    finally:
        view.close()
    assert client.subprotocol == "foxglove.sdk.v1"
    assert {c.topic: c.schema_name for c in client.channels.values()}["/map"] == "foxglove.Grid"

    grid = client.messages("/map")[-1].message
    assert grid["frame_id"] == MAP_FRAME
    assert grid["column_count"] == b5203_map.width
    assert grid["cell_size"]["x"] == pytest.approx(b5203_map.resolution)
    assert grid["pose"]["position"]["x"] == pytest.approx(b5203_map.origin.x)
    assert grid["pose"]["position"]["y"] == pytest.approx(b5203_map.origin.y)
    cells = grid_cells(grid)
    assert cells.shape == b5203_map.data.shape
    assert np.array_equal(cells["occupancy"], b5203_map.data)  # row 0 at the map's origin, as map_server's
    assert set(np.unique(cells["red"][b5203_map.data == 100])) == {0}  # occupied is black
    assert set(np.unique(cells["red"][b5203_map.data == 0])) == {254}  # free is light

    served_goals = client.messages("/patrol/goals")[-1].message["poses"]
    assert len(served_goals) == len(goals)
    for served, goal in zip(served_goals, goals, strict=True):
        assert served["position"]["x"] == pytest.approx(goal.x)
        assert served["position"]["y"] == pytest.approx(goal.y)
        assert yaw_of(served["orientation"]) == pytest.approx(goal.yaw, abs=1e-9)
    labels = [t["text"] for t in client.messages("/patrol/labels")[-1].message["entities"][0]["texts"]]
    assert labels[:2] == ["POSE_0", "POSE_1"] and "station" in labels

    poses = [m.message for m in client.messages("/robot/pose")]
    assert all(p["frame_id"] == MAP_FRAME for p in poses)
    last = poses[-1]["pose"]
    assert last["position"]["x"] == pytest.approx(end.x)
    assert last["position"]["y"] == pytest.approx(end.y)
    assert yaw_of(last["orientation"]) == pytest.approx(end.yaw, abs=1e-9)
    times = [m.log_time for m in client.messages("/robot/pose")]
    assert times == sorted(times)  # simulated time, forwards
    assert (times[-1] - times[0]) / 1e9 == pytest.approx(summary.sim_time, abs=0.25)

    scans = [m.message for m in client.messages("/robot/scan")]
    assert scans, "the first scan is always served to a subscribed viewer"
    assert scans[0]["frame_id"] == ROBOT_FRAME
    assert len(scans[0]["ranges"]) == sim.config.laser.beams
    assert scans[0]["end_angle"] - scans[0]["start_angle"] == pytest.approx(sim.config.laser.fov, rel=0.01)

    states = [m.message for m in client.messages("/patrol/state")]
    assert states[-1]["states"] == list(machine.active_states())
    assert states[-1]["states"] == ["SHUTDOWN"]


def test_objrec_patrol_foxglove_serves_a_late_viewer_the_map(tmp_path):
    """The command, in real time: a viewer connecting after the start still gets the map (resent on subscribe),
    then poses; SIGTERM ends the patrol cleanly, summary printed."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    command = [sys.executable, "-m", "navigation", POSES, "--map", MAP, "--realtime", "--foxglove", "127.0.0.1:0"]
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env) as patrol:
        try:
            line = patrol.stderr.readline()
            assert "Foxglove live view on ws://127.0.0.1:" in line, line
            url = line.rsplit(" ", 1)[1].strip()
            with FoxgloveClient(url, ["/map", "/robot/pose"]) as client:
                assert client.wait_for(lambda c: c.messages("/map") and c.messages("/robot/pose"), HANG_GUARD), \
                    client.error
        finally:
            patrol.send_signal(signal.SIGTERM)
            out, err = patrol.communicate(timeout=HANG_GUARD)
    assert patrol.returncode == 0, err
    assert "outcome:" in out and "SHUTDOWN" in out
    grid = client.messages("/map")[0].message
    occupancy = grid_cells(grid)["occupancy"]
    from navigation.maps import load_map

    assert np.array_equal(occupancy, load_map(MAP).data)
    pose = client.messages("/robot/pose")[0].message["pose"]["position"]
    assert 13.0 < pose["x"] < 16.0 and 12.0 < pose["y"] < 14.0  # at the start, the station pose (14.4, 12.8)


@pytest.mark.parametrize(("value", "why"), [
    ("70000", "--foxglove: port 70000 is above the maximum 65535"),
    ("host:", "--foxglove: 'host:': no port after the colon"),
    (":8765", "--foxglove: ':8765': no host before the colon"),
    ("port", "--foxglove: port 'port' is not a whole number"),
])
def test_bad_foxglove_value_is_one_line_exit_2(capsys, value, why):
    with pytest.raises(SystemExit) as exc:
        main([POSES, "--map", MAP, f"--foxglove={value}"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("objrec-patrol: error: ") and why in err, err


def test_a_port_in_use_is_one_line_exit_2(capsys):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main([POSES, "--map", MAP, "--laps", "1", "--foxglove", f"127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"objrec-patrol: error: --foxglove 127.0.0.1:{port}: cannot listen")


def test_a_live_robot_serves_the_pose_it_reports_and_no_simulated_scan(b5203_map):
    """A robot that is not the simulator (``--robot ros1``): the view reads only the PatrolRobot surface."""
    from types import SimpleNamespace

    from navigation.clock import SimClock
    from navigation.events import EventLog
    from navigation.geometry import Pose2D

    clock = SimClock(0.1)
    reported = Pose2D(3.0, 4.0, 0.5)
    battery = SimpleNamespace(percentage=80.0)
    robot = SimpleNamespace(clock=clock, events=EventLog(lambda: clock.now), move_base=SimpleNamespace(),
                            robot_battery=battery, laptop_battery=battery, pose_estimate=lambda: reported)
    view = open_patrol_view(parse_address("0"), robot, b5203_map)
    try:
        with FoxgloveClient(view.server.url, ["/robot/pose", "/robot/scan", "/map"]) as client:
            assert client.wait_for(lambda c: view.server.wanted(view.pose) and view.server.wanted(view.scan),
                                   HANG_GUARD), client.error
            view.sample()
            assert client.wait_for(lambda c: c.messages("/robot/pose") and c.messages("/map"), HANG_GUARD)
    finally:
        view.close()
    assert len(view._timers) == 1  # poses only: the simulator's scans are cast on the map, a robot's are its own
    pose = client.messages("/robot/pose")[-1].message["pose"]
    assert (pose["position"]["x"], pose["position"]["y"]) == (3.0, 4.0)
    assert yaw_of(pose["orientation"]) == pytest.approx(0.5)
    assert client.messages("/robot/scan") == []


def test_without_foxglove_sdk_the_error_names_the_extra(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "foxglove", None)  # as if not installed: importing it fails
    assert main([POSES, "--map", MAP, "--laps", "1", "--foxglove", "0"]) == 2
    out, err = capsys.readouterr()
    assert err == "objrec-patrol: error: --foxglove needs the viz extra: pip install 'objrec[viz]'\n"
    assert out == ""
