"""Pictures and animations of a run, and the Mermaid diagram of the machine."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from navigation.diagram import mermaid, write_diagram
from navigation.docking import DockingStation
from navigation.patrol import patrol_states
from navigation.render import RunPicture, render_still, save_render
from navigation.runner import run_patrol

ALL_STATES = ["MONITORED_PATROL", "PATROL", "ROBOT_BATTERY_MONITOR", "POSE_0",
              "POSE_1", "POSE_2", "DOCK_AT_STATION", "MOVE_TO_STATION", "DOCK", "WAIT_UNTIL_CHARGED",
              "UNDOCK", "SHUTDOWN"]


@pytest.fixture(scope="module")
def picture(b5203_map, b5203_poses) -> RunPicture:
    from navigation.patrol import PatrolMachine
    from navigation.simulation import Simulation

    goals = list(b5203_poses.goals[:5])
    dock = DockingStation.in_front_of(b5203_poses.station)
    sim = Simulation(b5203_map, b5203_poses.station, station=dock)
    machine = PatrolMachine(sim, goals, b5203_poses.station, max_laps=1)
    states: list[tuple[float, str]] = []
    machine.state_listeners.append(lambda m: states.append((sim.clock.now, m.entering)))
    run_patrol(machine, handle_sigint=False)
    return RunPicture(b5203_map, sim.trajectory, goals, b5203_poses.station, dock, sim.collision_points,
                      caption="test run", states=states)


def test_still_picture_shows_the_path_goals_and_station(picture, tmp_path):
    img = render_still(picture)
    assert img.ndim == 3 and max(img.shape[:2]) >= 700

    def near(colour: tuple[int, int, int]) -> int:  # pixels drawn in a colour, anti-aliasing allowed
        return int((np.abs(img.astype(int) - colour).sum(axis=2) < 60).sum())

    assert near((200, 110, 20)) > 500  # the driven path
    assert near((30, 30, 220)) > 100  # five goals with arrows and numbers
    assert near((40, 160, 40)) > 100  # station arrow and dock
    out = save_render(tmp_path / "run.png", picture)
    assert cv2.imread(str(out)).shape == img.shape


def test_gif_animation(picture, tmp_path):
    out = save_render(tmp_path / "run.gif", picture)
    ok, anim = cv2.imreadanimation(str(out))
    assert ok and 100 <= len(anim.frames) <= 150
    # The robot moves: first and last frames differ.
    assert np.abs(anim.frames[0].astype(int) - anim.frames[-1].astype(int)).sum() > 0


@pytest.mark.parametrize("ext", [".avi", ".mp4"])
def test_video_animation(picture, tmp_path, ext):
    out = save_render(tmp_path / f"run{ext}", picture)
    cap = cv2.VideoCapture(str(out))
    assert cap.isOpened()
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == min(300, len(picture.trajectory))
    cap.release()


def test_unknown_extension_is_refused(picture, tmp_path):
    with pytest.raises(ValueError, match="cannot render"):
        save_render(tmp_path / "run.tiff", picture)


def test_mermaid_has_every_state_and_the_parallel_regions():
    text = mermaid(3)
    assert text.startswith("stateDiagram-v2\n")
    for name in ALL_STATES:
        assert name in text
    assert "state MONITORED_PATROL {" in text and "state PATROL {" in text
    assert text.count("\n        --\n") == 1  # two concurrent regions inside MONITORED_PATROL (no added monitor)
    assert "POSE_2 --> POSE_0 : succeeded, aborted" in text
    assert "MONITORED_PATROL --> DOCK_AT_STATION : robot_battery_low [has_station] from ROBOT_BATTERY_MONITOR" in text
    assert "WAIT_UNTIL_CHARGED --> UNDOCK : charged [resume_after_charging]" in text
    assert "SHUTDOWN --> [*] : shutdown" in text
    assert "ACTIVE" not in text


def test_mermaid_marks_the_active_states(tmp_path):
    active = ["MONITORED_PATROL", "MONITORED_PATROL.PATROL", "MONITORED_PATROL.PATROL.POSE_1",
              "MONITORED_PATROL.ROBOT_BATTERY_MONITOR"]
    text = mermaid(3, active)
    assert "POSE_1 : ACTIVE" in text and "POSE_0 : ACTIVE" not in text
    assert "ROBOT_BATTERY_MONITOR : ACTIVE" in text
    assert "class MONITORED_PATROL,PATROL,POSE_1,ROBOT_BATTERY_MONITOR active" in text
    raw = write_diagram(tmp_path / "m.mmd", 3, active).read_text()
    assert raw == text
    assert len(patrol_states(3)) == 6
