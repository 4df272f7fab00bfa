"""The inspection report a person can trust: every expected object is listed, a run cut short
says why an object was not checked, the Markdown and the JSON agree, and a 2D detection (placed on the face
the camera sees) is lifted to the object's centre before it is judged."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from navigation.world import load_world
from objrec_apps.inspect import main
from objrec_apps.inspection import open_inspection
from objrec_apps.inspection.verdict import Found, lift_to_centre

ROOT = Path(__file__).resolve().parents[2]
LAB = ROOT / "examples" / "inspection_lab"
MISSION, MAP, WORLD = LAB / "mission.yaml", LAB / "lab.yaml", LAB / "lab.world.yaml"


def stopping_mission(tmp_path: Path) -> Path:
    """The example mission with its third goal (the red box's) moved into the crate: the goal aborts, and
    ``stop_on_failure`` ends the mission there, before the blue ball's pose."""
    poses = (LAB / "lab_poses.txt").read_text().splitlines()
    goals = [i for i, line in enumerate(poses) if line and line[0].isdigit()]
    poses[goals[2]] = "5.75, 3.2, 0.0, 0.0, 0.0, 0.0, 1.0"
    (tmp_path / "poses.txt").write_text("\n".join(poses) + "\n")
    text = (LAB / "mission.yaml").read_text().replace("lab_poses.txt", str(tmp_path / "poses.txt"))
    text = text.replace("stop_on_failure: false", "stop_on_failure: true")
    for name in ("params/", "poster.png"):
        text = text.replace(name, f"{LAB / name}{'/' if name.endswith('/') else ''}")
    path = tmp_path / "mission.yaml"
    path.write_text(text)
    return path


def test_after_stop_on_failure_every_expected_object_is_listed_with_why(tmp_path, capsys, caplog):
    out = tmp_path / "out"
    assert main([str(stopping_mission(tmp_path)), "--map", str(MAP), "--world", str(WORLD), "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    # Warned before the run, as objrec-patrol does.
    assert [(r.levelname, r.getMessage()) for r in caplog.records if r.name == "objrec.inspect"] == [
        ("WARNING", "goal POSE_2 (5.75, 3.20) is inside 'crate' of the world; it will be aborted")]
    report = json.loads((out / "report.json").read_text())
    objects = report["objects"]
    assert list(objects) == ["green_cylinder", "poster", "red_box", "blue_ball"]
    assert [v["pose"] for v in report["visits"]] == ["POSE_0", "POSE_1", "POSE_2"]
    assert report["visits"][2]["goal_status"] == "ABORTED"
    assert {k: o["status"] for k, o in objects.items()} == {
        "green_cylinder": "present", "poster": "present", "red_box": "not_checked", "blue_ball": "not_checked"}
    assert objects["red_box"]["reason"] == "goal aborted at POSE_2" and objects["red_box"]["visit"] == 3
    assert objects["blue_ball"]["visit"] is None
    assert objects["blue_ball"]["reason"] == "mission stopped after visit 3 (goal aborted at POSE_2; stop_on_failure)"
    # The Markdown says the same, object by object.
    markdown = (out / "report.md").read_text()
    for name, o in objects.items():
        row = next(line for line in markdown.splitlines() if line.startswith(f"| {name} | "))
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[1] == o["status"].replace("_", " ")
        assert cells[4] == ("-" if o["visit"] is None else str(o["visit"]))
        assert cells[5] == (o["reason"] or "-")
    assert "blue_ball:      not checked: mission stopped after visit 3" in stdout


def test_a_run_cut_by_its_time_limit_names_the_limit(tmp_path):
    inspection = open_inspection(MISSION, MAP, WORLD)
    summary = inspection.run(time_limit=20.0, handle_sigint=False)
    verdicts = inspection.report.verdicts(summary.as_dict())
    assert set(verdicts) == {"green_cylinder", "poster", "red_box", "blue_ball"}
    unvisited = [v for n, v in verdicts.values() if n is None]
    assert unvisited and all(v.status == "not_checked" for v in unvisited)
    assert all(v.reason.startswith(f"run ended ({summary.outcome}") for v in unvisited), unvisited


def test_a_box_moved_toward_the_camera_within_tolerance_is_present(tmp_path):
    """The red box moved 0.35 m toward the robot at its pose (tolerance 0.5 m): its 2D detection sits on the near
    face, 0.2 m in front of the centre; lifted by the box's known size it is 0.30 m off, present."""
    camera, box = (5.4, 1.6), (7.0, 1.3)
    d = math.dist(camera, box)
    shift = (0.35 * (camera[0] - box[0]) / d, 0.35 * (camera[1] - box[1]) / d)
    inspection = open_inspection(MISSION, MAP, WORLD, shift=[("red_box", *shift)])
    inspection.run(handle_sigint=False)
    _, verdict = inspection.report.objects["red_box"]
    assert verdict.status == "present", verdict
    assert verdict.found is not None and verdict.found.method == "polygon"
    assert 0.15 < verdict.found.lifted < 0.3  # the box is 0.4 m deep, seen obliquely
    assert abs(verdict.error - 0.35) < 0.1
    assert math.dist((verdict.found.x, verdict.found.y), (box[0] + shift[0], box[1] + shift[1])) < 0.1


@pytest.mark.parametrize(("name", "depth"), [("red_box", 0.2), ("green_cylinder", 0.12), ("poster", 0.01)])
def test_lifting_moves_a_seen_face_to_the_centre_along_the_line_of_sight(name, depth):
    thing = next(o for o in load_world(WORLD).objects if o.name == name)
    if name == "red_box":  # a 0.4 m box turned 0.3 rad: entered obliquely, a little deeper than half
        depth = 0.2 / math.cos(0.3)
    camera = (thing.x - 2.0, thing.y)  # looking along +x
    face = Found(name, thing.x - depth, thing.y, 0.3, "polygon", 1, camera)
    lifted = lift_to_centre(face, thing)
    assert lifted.lifted == pytest.approx(depth, abs=1e-6)
    assert (lifted.x, lifted.y) == pytest.approx((thing.x, thing.y), abs=1e-6)
    box = Found(name, thing.x - depth, thing.y, 0.3, "box", 1, camera)
    assert lift_to_centre(box, thing) is box  # a 3D box is already a centre


# -- the picture ------------------------------------------------------------------------------------------
def test_the_picture_marks_collisions_aborted_goals_and_unchecked_objects_apart(tmp_path):
    from objrec_apps.inspection.picture import ABORTED_GOAL, COLLISION, UNCHECKED, _band

    inspection = open_inspection(stopping_mission(tmp_path), MAP, WORLD)
    summary = inspection.run(handle_sigint=False)
    plain = inspection.picture(summary)
    inspection.sim.collision_points.append((3.0, 3.0))  # a collision drawn where nothing else is
    marked = inspection.picture(summary)
    assert (marked == COLLISION).all(axis=2).sum() > (plain == COLLISION).all(axis=2).sum() + 20
    assert (plain == ABORTED_GOAL).all(axis=2).sum() > 20  # the aborted goal POSE_2
    assert (plain == UNCHECKED).all(axis=2).sum() > 20  # the red box and the blue ball: not checked
    # The legend wraps on a narrow picture instead of running off it.
    assert _band(300, "caption", 0.4).shape[0] > 2 * _band(2000, "caption", 0.4).shape[0]
