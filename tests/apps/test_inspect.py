"""objrec-inspect and what it is made of: the kind's camera-frame contract, the mission file, the detect
task, the example lab mission end to end (present, absent, moved), the command's outputs, errors and Ctrl-C."""

from __future__ import annotations

import contextlib
import json
import math
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from navigation.tasks import TaskSpecError, make_task
from navigation.world import load_world
from objrec_apps.inspect import main
from objrec_apps.inspection import InspectionError, load_mission, open_inspection
from objrec_apps.inspection.detect_task import DetectTask
from objrec_apps.inspection.mission import MissionError
from objrec_core import get_kind, register_kind, register_module
from objrec_core.registry import unregister_kind, unregister_module
from tests.signal_steps import signal_during, signal_once_working

ROOT = Path(__file__).resolve().parents[2]
LAB = ROOT / "examples" / "inspection_lab"
MISSION, MAP, WORLD = LAB / "mission.yaml", LAB / "lab.yaml", LAB / "lab.world.yaml"
#: How close the example's objects must be placed: 3D boxes and 2D polygons (by their depth).
BOX_TOLERANCE, POLYGON_TOLERANCE = 0.15, 0.3


# -- the kind contract: camera frames ----------------------------------------------------------------------
# (a kind without camera frames: tests/apps/test_inspect_camera_frames.py, with the app's TakesRGBD protocol)
def test_image_kind_takes_the_colour_image():
    color = np.random.default_rng(0).integers(0, 255, (4, 6, 3), dtype=np.uint8)
    image = get_kind("2d").from_rgbd(color, np.ones((4, 6), np.float32), 5.0, 5.0, 2.5, 1.5)
    assert image.dtype == np.uint8 and np.array_equal(image, color) and image is not color


def test_cloud_kind_makes_an_organized_cloud_in_the_optical_frame():
    color = np.zeros((3, 4, 3), np.uint8)
    color[..., 0], color[..., 2] = 200, 10  # BGR: blue
    depth = np.full((3, 4), 2.0, np.float32)
    depth[0, 0], depth[0, 1] = np.nan, 0.0
    cloud = get_kind("3d").from_rgbd(color, depth, 100.0, 50.0, 1.5, 1.0)
    assert (cloud.width, cloud.height) == (4, 3) and cloud.is_organized
    grid = cloud.grid()
    assert np.isnan(grid[0, 0]).all() and np.isnan(grid[0, 1]).all()
    np.testing.assert_allclose(grid[2, 3], [(3 - 1.5) / 100.0 * 2.0, (2 - 1.0) / 50.0 * 2.0, 2.0], rtol=1e-6)
    assert tuple(cloud.colors[5]) == (10, 0, 200)  # RGB


# -- the mission file -----------------------------------------------------------------------------------
def test_the_example_mission_loads():
    mission = load_mission(MISSION)
    assert len(mission.poses.goals) == 4
    assert (mission.first_pose, mission.laps, mission.stop_on_failure) == (0, 1, False)
    assert [[t.kind for t in row] for row in mission.tasks] == [
        ["look_around", "detect"], ["photo", "detect"], ["wait", "detect"], ["detect"]]
    assert [[e.name for e in row] for row in mission.expected] == [["green_cylinder"], ["poster"], ["red_box"],
                                                                    ["blue_ball"]]
    assert mission.tasks[3][0].labels == ["blue_ball", "green_cylinder"]
    assert mission.expected[0][0].tolerance == 0.5


def write_mission(tmp_path: Path, text: str) -> Path:
    (tmp_path / "poses.txt").write_text("1, 1, 0, 0, 0, 0, 1\n2, 1, 0, 0, 0, 0, 1\n")
    path = tmp_path / "mission.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "message"), [
    ("poses: poses.txt\nwhen: now\n", "mission.yaml:2: when: unknown key (allowed: poses, first_pose,"),
    ("tasks: []\n", "mission.yaml:1: poses: missing (the goal-pose file)"),
    ("poses: nowhere.txt\n", "nowhere.txt: pose file not found"),
    ("poses: poses.txt\nfirst_pose: 2\n", "mission.yaml:2: first_pose: 2 is invalid: not one of the 2 poses"),
    ("poses: poses.txt\nlaps: 0\n", "mission.yaml:2: laps: 0 is invalid: out of range, allowed int in 1..100000"),
    ("poses: poses.txt\ntolerance: -1\n",
     "mission.yaml:2: tolerance: -1 is invalid: out of range, allowed float in (0..1000000]"),
    ("poses: poses.txt\nstop_on_failure: maybe\n",
     "mission.yaml:2: stop_on_failure: 'maybe' is invalid: expected true or false"),
    ("poses: poses.txt\ntasks: [dance]\n", "mission.yaml:2: tasks[0]: 'dance' is invalid: unknown task (known: "),
    ("poses: poses.txt\ntasks: [{wait: {seconds: x}}]\n",
     "mission.yaml:2: tasks[0].wait.seconds: 'x' is invalid: expected a number"),
    ("poses: poses.txt\nat: {5: {expect: [a]}}\n", "mission.yaml:2: at.5: 5 is invalid: not a pose index: "),
    ("poses: poses.txt\nat: {1: {expect: [a, a]}}\n", "mission.yaml:2: at.1.expect[1]: object 'a' is expected twice"),
    ("poses: poses.txt\nat: {1: {expect: [{name: a, size: 2}]}}\n",
     "mission.yaml:2: at.1.expect[0].size: unknown key (allowed: name, label, tolerance)"),
    ("poses: poses.txt\nat: {0: {tasks: [{detect: missing.yaml}]}}\n",
     "mission.yaml:2: at.0.tasks[0].detect.params: "),
    ("poses: poses.txt\nat: {0: {tasks: [detect]}}\n",
     "mission.yaml:2: at.0.tasks[0].detect.params: missing"),
    ("poses: [1, 2\n", "mission.yaml"),
])
def test_mission_errors_name_the_file_and_the_field(tmp_path, text, message):
    with pytest.raises(MissionError) as info:
        load_mission(write_mission(tmp_path, text))
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_a_mission_file_that_is_missing(tmp_path):
    with pytest.raises(MissionError, match=r"mission\.yaml: mission file not found"):
        load_mission(tmp_path / "mission.yaml")


def test_detect_refuses_files_that_cannot_take_camera_frames(tmp_path):
    no_detector = tmp_path / "filter_only.yaml"
    no_detector.write_text("format_version: 1\nobject_name: x\nkind: 2d\npipeline:\n- type: HSVFilter\n  id: f\n")
    with pytest.raises(TaskSpecError, match=r"^detect\.params: .*filter_only\.yaml has no detector, so nothing would"):
        make_task({"detect": str(no_detector)}, tmp_path)
    signal = r"^detect\.params: .*signal\.yaml: .*kind 'signal'.* cannot take camera"
    with signal_kind(tmp_path) as params, pytest.raises(TaskSpecError, match=signal):
        make_task({"detect": str(params)}, tmp_path)
    assert isinstance(make_task({"detect": "params/colour_2d.yaml"}, LAB), DetectTask)


@contextlib.contextmanager
def signal_kind(folder: Path) -> Iterator[Path]:
    """The third-party 1-D signal kind of tests/signal_kind, registered for the block only."""
    plugin = ROOT / "tests" / "signal_kind"
    sys.path.insert(0, str(plugin))
    try:
        import objrec_signal

        register_kind(objrec_signal.SignalKind)
        register_module(objrec_signal.MovingAverageFilter)
        register_module(objrec_signal.PeakDetector)
        path = folder / "signal.yaml"
        path.write_text("format_version: 1\nobject_name: bump\nkind: signal\npipeline:\n"
                        "- type: PeakDetector\n  id: peaks\n")
        yield path
    finally:
        unregister_kind("signal")
        unregister_module("MovingAverageFilter")
        unregister_module("PeakDetector")
        sys.path.remove(str(plugin))
        for name in [n for n in sys.modules if n == "objrec_signal" or n.startswith("objrec_signal.")]:
            del sys.modules[name]


# -- the example lab end to end -------------------------------------------------------------------------
def objects_by_name(inspection) -> dict:
    return {name: v for name, (_, v) in inspection.report.objects.items()}


def test_the_example_mission_finds_every_expected_object_where_the_world_file_puts_it(tmp_path):
    inspection = open_inspection(MISSION, MAP, WORLD, out_dir=tmp_path)
    summary = inspection.run(handle_sigint=False)
    assert summary.outcome == "shutdown" and summary.final_states == ("SHUTDOWN",)
    assert (summary.goals_reached, summary.goals_aborted, summary.collisions) == (4, 0, 0)
    world = load_world(WORLD)
    verdicts = objects_by_name(inspection)
    assert set(verdicts) == {"green_cylinder", "poster", "red_box", "blue_ball"}
    for name, v in verdicts.items():
        assert v.status == "present", (name, v)
        x, y, z = next(o for o in world.objects if o.name == name).centre
        limit = BOX_TOLERANCE if v.found.method == "box" else POLYGON_TOLERANCE
        assert math.dist((v.found.x, v.found.y, v.found.z), (x, y, z)) < limit, (name, v.found)
    assert {v.found.method for v in verdicts.values()} == {"box", "polygon"}
    # Every visit, in order, with its tasks done.
    visits = inspection.report.visits
    assert [(v["pose"], v["goal_status"]) for v in visits] == [(f"POSE_{i}", "SUCCEEDED") for i in range(4)]
    assert all(t["status"] == "succeeded" for v in visits for t in v["tasks"])
    # Nothing was found that is not in the room (no false detection anywhere).
    assert sorted(f["name"] for v in visits for f in v["found"]) == ["blue_ball", "green_cylinder", "poster",
                                                                      "red_box"]
    paths = inspection.write(summary)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["outcome"] == "shutdown" and report["summary"]["collisions"] == 0
    assert {k: o["status"] for k, o in report["objects"].items()} == dict.fromkeys(verdicts, "present")
    assert "| green_cylinder | present | 1.50, 5.30," in (tmp_path / "report.md").read_text()
    picture = cv2.imread(str(tmp_path / "map.png"))
    assert picture is not None and min(picture.shape[:2]) > 400
    assert [p.name for p in paths] == ["report.json", "report.md", "map.png"]
    photo = cv2.imread(str(tmp_path / "photos" / "visit002_POSE_1.png"))
    assert photo.shape == (480, 640, 3)


def test_a_removed_object_is_absent_and_shifted_ones_are_moved(tmp_path):
    inspection = open_inspection(MISSION, MAP, WORLD, remove=["blue_ball"],
                                 shift=[("red_box", 0.8, 0.0), ("green_cylinder", 0.6, 0.0)])
    summary = inspection.run(handle_sigint=False)
    assert summary.outcome == "shutdown" and summary.collisions == 0
    verdicts = objects_by_name(inspection)
    assert {k: v.status for k, v in verdicts.items()} == {
        "green_cylinder": "moved", "poster": "present", "red_box": "moved", "blue_ball": "absent"}
    cylinder, box = verdicts["green_cylinder"].found, verdicts["red_box"].found
    assert math.dist((cylinder.x, cylinder.y), (2.1, 5.3)) < BOX_TOLERANCE
    assert math.dist((box.x, box.y), (7.8, 1.3)) < POLYGON_TOLERANCE
    assert verdicts["blue_ball"].found is None and verdicts["blue_ball"].expected[:2] == (7.3, 4.4)
    assert inspection.report.sources["changes"] == ["blue_ball removed", "red_box shifted by (0.8, 0) m",
                                                    "green_cylinder shifted by (0.6, 0) m"]


def test_an_object_the_pose_does_not_look_for_is_not_checked(tmp_path):
    mission = tmp_path / "mission.yaml"
    colour = LAB / "params" / "colour_2d.yaml"
    mission.write_text(f"poses: {LAB / 'lab_poses.txt'}\nat:\n  3:\n    tasks: [{{detect: {colour}}}]\n"
                       "    expect: [blue_ball]\n")
    inspection = open_inspection(mission, MAP, WORLD, start=None)
    inspection.run(handle_sigint=False)
    assert objects_by_name(inspection)["blue_ball"].status == "not_checked"


def test_expected_objects_must_be_in_the_world_file(tmp_path):
    mission = tmp_path / "mission.yaml"
    mission.write_text(f"poses: {LAB / 'lab_poses.txt'}\nat: {{2: {{expect: [unicorn]}}}}\n")
    with pytest.raises(InspectionError, match=r"mission.yaml: at.2.expect\[0\]: no object 'unicorn' in the world"):
        open_inspection(mission, MAP, WORLD)


# -- the command ----------------------------------------------------------------------------------------
def test_the_command_writes_every_output(tmp_path, capsys):
    out = tmp_path / "out"
    code = main([str(MISSION), "--map", str(MAP), "--world", str(WORLD), "--out", str(out), "--remove", "poster",
                 "--diagram", str(out / "machine.md")])
    assert code == 0
    text = capsys.readouterr().out
    assert "outcome:        shutdown" in text and "collisions:     0" in text
    assert "poster:         absent (visit 2)" in text
    assert "green_cylinder: present at (1.50, 5.30), 0.00 m off (visit 1)" in text
    assert sorted(p.name for p in out.iterdir()) == ["events.jsonl", "machine.md", "map.png", "photos", "report.json",
                                                     "report.md"]
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    kinds = {e["type"] for e in events}
    assert {"task_start", "task_result", "detection", "visit", "outcome"} <= kinds
    detections = [e for e in events if e["type"] == "detection"]
    assert {d["name"] for d in detections} == {"green_cylinder", "red_box", "blue_ball"}
    assert all(d["state"].startswith("MONITORED_PATROL.PATROL.POSE_") for d in detections)
    diagram = (out / "machine.md").read_text()
    assert "POSE_0_LOOK_AROUND --> POSE_0_DETECT : succeeded" in diagram and "SHUTDOWN : ACTIVE" in diagram


@pytest.mark.parametrize(("args", "message"), [
    (["--shift", "red_box", "1", "x"], "--shift: DY: 'x' is not a number"),
    (["--remove", "unicorn"], "no object or obstacle named 'unicorn' in the world"),
    (["--laps", "0"], "--laps: 0 is below the minimum 1"),
    (["--start", "0", "0", "0"], "start pose (0.000, 0.000) puts the robot"),
])
def test_command_errors_are_one_line_and_exit_2(tmp_path, capsys, args, message):
    try:  # a malformed number is refused while parsing (SystemExit), a bad world state by main's return
        code = main([str(MISSION), "--map", str(MAP), "--world", str(WORLD), "--out", str(tmp_path / "o"), *args])
    except SystemExit as exit:
        code = exit.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("objrec-inspect: error: ") and message in err and err.count("\n") == 1


def test_a_bad_world_file_names_the_file(tmp_path, capsys):
    world = tmp_path / "w.yaml"
    world.write_text("objects:\n  - {name: a, shape: cone, x: 1, y: 1}\n")
    assert main([str(MISSION), "--map", str(MAP), "--world", str(world), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "w.yaml" in err and "cone" in err and err.count("\n") == 1


def test_ctrl_c_ends_in_shutdown_with_the_report_so_far(tmp_path):
    """A real Ctrl-C while the robot looks around at its first pose (in real time, starting there)."""
    out = tmp_path / "out"
    events = out / "events.jsonl"
    code, stdout, stderr = signal_once_working(
        [sys.executable, "-m", "objrec_apps.inspect", str(MISSION), "--map", str(MAP), "--world", str(WORLD),
         "--out", str(out), "--realtime", "--start", "2.8", "4.5", "2.59"],
        lambda: events.exists() and "POSE_0_LOOK_AROUND" in events.read_text(), signal.SIGINT, after=0.5)
    assert code == 0, stderr
    assert "outcome:        shutdown (SIGINT)" in stdout
    report = json.loads((out / "report.json").read_text())
    assert report["summary"]["reason"] == "SIGINT" and report["outcome"] == "shutdown"
    assert [v["pose"] for v in report["visits"]] == ["POSE_0"]
    assert report["visits"][0]["tasks"] == [{"state": "POSE_0_LOOK_AROUND", "task": "look_around",
                                             "status": "preempted", "text": "state left"}]
    assert report["objects"]["green_cylinder"]["status"] == "not_checked"
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    assert lines[-1]["type"] == "outcome" and any(e["type"] == "preempt_requested" for e in lines)
    assert (out / "map.png").is_file() and "POSE_0_LOOK_AROUND: preempted" in (out / "report.md").read_text()


def test_ctrl_c_during_start_up_still_reports(tmp_path, capsys, monkeypatch):
    import objrec_apps.inspection.session as session

    signal_during(monkeypatch, session, "load_world", signal.SIGINT)
    out = tmp_path / "out"
    assert main([str(MISSION), "--map", str(MAP), "--world", str(WORLD), "--out", str(out)]) == 0
    assert "outcome:        shutdown (SIGINT)" in capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert report["outcome"] == "shutdown" and report["objects"]["green_cylinder"]["status"] == "not_checked"
    lines = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    assert lines[0]["type"] == "preempt_requested" and lines[-1]["type"] == "outcome"


def test_with_amcl_and_noisy_odometry_objects_are_placed_from_the_believed_pose(tmp_path):
    from dataclasses import replace

    from navigation.simulation import SimConfig

    config = replace(SimConfig(), localization="amcl", odom_linear_noise=0.05, odom_angular_noise=0.05, seed=1)
    inspection = open_inspection(MISSION, MAP, WORLD, config=config)
    summary = inspection.run(handle_sigint=False)
    assert summary.collisions == 0 and summary.goals_reached == 4
    assert {k: v.status for k, v in objects_by_name(inspection).items()} == dict.fromkeys(
        ["green_cylinder", "poster", "red_box", "blue_ball"], "present")
