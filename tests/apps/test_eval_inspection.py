"""objrec-eval's inspection part: an objrec-inspect report's present/absent/moved verdicts scored against the
world the robot met (the world file, with --remove/--shift applied), per object and over the mission."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import cv2
import pytest

from navigation.world import load_world
from objrec_apps.cli import UserError
from objrec_apps.eval_inspection import (
    Confusion,
    add_inspection_arguments,
    inspection_confusion,
    inspection_evaluation,
    truth_world,
)
from objrec_apps.inspect import main as inspect_main
from strictio.cli_numbers import CommandLineParser

ROOT = Path(__file__).resolve().parents[2]
LAB = ROOT / "examples" / "inspection_lab"
MISSION, MAP, WORLD = LAB / "mission.yaml", LAB / "lab.yaml", LAB / "lab.world.yaml"
#: The robot meets the lab without the ball, the box 0.8 m east (moved: beyond the 0.5 m tolerance) and the
#: cylinder 0.2 m east (still present: within it).
CHANGES = ["--remove", "blue_ball", "--shift", "red_box", "0.8", "0", "--shift", "green_cylinder", "0.2", "0"]


@pytest.fixture(scope="module")
def changed_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """report.json of the example mission in the changed lab (one real objrec-inspect run)."""
    out = tmp_path_factory.mktemp("inspection")
    code = inspect_main([str(MISSION), "--map", str(MAP), "--world", str(WORLD), "--out", str(out), *CHANGES])
    assert code == 0
    return out / "report.json"


def parse(*argv: str) -> argparse.Namespace:
    parser = CommandLineParser(prog="objrec-eval")
    parser.add_argument("--truth")
    add_inspection_arguments(parser)
    return parser.parse_args(list(argv))


def test_every_verdict_of_the_changed_lab_matches_its_truth(changed_report):
    report = json.loads(changed_report.read_text())
    assert [v["status"] for v in report["objects"].values()] == ["present", "present", "moved", "absent"]
    world, changes = truth_world(WORLD, ["blue_ball"], [("red_box", 0.8, 0.0), ("green_cylinder", 0.2, 0.0)])
    confusion = inspection_confusion(changed_report, world)
    assert confusion.counts == {"green_cylinder": {("present", "present"): 1}, "poster": {("present", "present"): 1},
                                "red_box": {("moved", "moved"): 1}, "blue_ball": {("absent", "absent"): 1}}
    assert confusion.frames == 4 and confusion.score == 1.0
    every = confusion.summary_rows()[-1]
    assert every == {"name": "all", "judgements": 4, "checked": 4, "right": 4, "accuracy": 1.0, "coverage": 1.0,
                     "score": 1.0, "missed_changes": 0, "false_alarms": 0}
    assert confusion.below({"accuracy": 1.0, "score": 1.0}) == []
    assert changes == ["blue_ball removed", "red_box shifted by (0.8, 0) m", "green_cylinder shifted by (0.2, 0) m"]


def test_against_the_unchanged_world_the_changes_are_false_alarms(changed_report):
    confusion = inspection_confusion(changed_report, load_world(WORLD))
    assert confusion.matrix() == {("present", "present"): 2, ("present", "moved"): 1, ("present", "absent"): 1}
    rows = {r["name"]: r for r in confusion.summary_rows()}
    assert rows["all"]["false_alarms"] == 2 and rows["all"]["right"] == 2 and confusion.score == 0.5
    assert rows["blue_ball"]["accuracy"] == 0.0 and rows["poster"]["accuracy"] == 1.0
    assert confusion.below({"score": 0.9, "coverage": 1.0}) == ["score 0.500 < 0.9"]


def test_the_report_s_own_changes_are_the_truth_by_default(changed_report):
    confusion = inspection_evaluation(parse("--inspection", str(changed_report)))
    assert confusion.score == 1.0
    assert confusion.changes == ["blue_ball removed", "red_box shifted by (0.8, 0) m",
                                 "green_cylinder shifted by (0.2, 0) m"]
    assert confusion.world == str(WORLD) and confusion.report == str(changed_report)
    data = json.loads(json.dumps(confusion.to_dict()))
    assert data["confusion"]["all"]["absent"] == {"present": 0, "absent": 1, "moved": 0, "not_checked": 0}
    assert data["confusion"]["red_box"]["moved"]["moved"] == 1 and data["score"] == 1.0


def test_the_picture_shades_each_cell_by_its_share_of_the_row(changed_report, tmp_path):
    confusion = inspection_evaluation(parse("--inspection", str(changed_report), "--remove", "blue_ball"))
    [path] = confusion.pictures(tmp_path)
    picture = cv2.imread(str(path))
    assert path.name == "inspection-confusion.png" and picture.shape[1] == 96 + 4 * 64 + 16
    # The mission's matrix comes first; cell (truth, verdict) spans 62 px from x 96 + 64 c, y 40 + 64 r.
    def shade(r: int, c: int) -> tuple[int, ...]:
        return tuple(int(v) for v in picture[40 + 64 * r + 4, 96 + 64 * c + 4])
    assert shade(0, 0) == (255 - round(2 / 3 * 195), 255 - round(2 / 3 * 85), 255 - round(2 / 3 * 215))  # 2 of 3
    assert shade(0, 2) == (255 - round(1 / 3 * 215), 255 - round(1 / 3 * 215), 255 - round(1 / 3 * 35))  # 1 of 3
    assert shade(1, 1) == (60, 170, 40) and shade(2, 2) == (255, 255, 255)  # all of its row; an empty row


def test_remove_and_shift_given_replace_the_report_s_changes(changed_report):
    # Only the ball removed: the box's move and the cylinder's small shift are not in this truth.
    confusion = inspection_evaluation(parse("--inspection", str(changed_report), "--truth", str(WORLD),
                                            "--remove", "blue_ball"))
    assert confusion.changes == ["blue_ball removed"]
    assert confusion.matrix("red_box") == {("present", "moved"): 1}
    assert confusion.matrix("blue_ball") == {("absent", "absent"): 1}
    assert confusion.score == 0.75
    # The box shifted by less than the tolerance: truly present, so the report's "moved" is a false alarm too.
    confusion = inspection_evaluation(parse("--inspection", str(changed_report), "--shift", "red_box", "0.4", "0",
                                            "--remove", "blue_ball"))
    assert confusion.matrix("red_box") == {("present", "moved"): 1} and confusion.score == 0.75
    confusion = inspection_evaluation(parse("--inspection", str(changed_report), "--shift", "red_box", "0", "0.6",
                                            "--remove", "blue_ball"))
    assert confusion.matrix("red_box") == {("moved", "moved"): 1} and confusion.score == 1.0


def verdict(name: str, status: str, x: float = 1.0, y: float = 2.0, tolerance: float = 0.5) -> dict[str, Any]:
    return {"name": name, "label": name, "status": status, "expected": {"x": x, "y": y, "z": 0.3},
            "tolerance_m": tolerance}


def test_unchecked_verdicts_lower_the_score_and_missed_changes_are_counted(tmp_path):
    world_file = tmp_path / "w.world.yaml"
    world_file.write_text("objects:\n  - {name: can, shape: cylinder, x: 1.0, y: 2.0, radius: 0.1, height: 0.3}\n"
                          "  - {name: ball, shape: sphere, x: 4.0, y: 2.0, radius: 0.1}\n")
    report = {"visits": [{"expected": [verdict("can", "present"), verdict("ball", "not_checked", 4.0)]},
                         {"expected": [verdict("can", "present"), verdict("ball", "absent", 4.0)]},
                         {"expected": []}]}
    world, _ = truth_world(world_file, ["ball"], [("can", 0.0, 0.7)])
    confusion = inspection_confusion(report, world)
    assert confusion.frames == 3
    assert confusion.matrix() == {("moved", "present"): 2, ("absent", "not_checked"): 1, ("absent", "absent"): 1}
    every = confusion.summary_rows()[-1]
    assert (every["judgements"], every["checked"], every["right"]) == (4, 3, 1)
    assert every["accuracy"] == pytest.approx(1 / 3) and every["coverage"] == 0.75 and confusion.score == 0.25
    assert every["missed_changes"] == 2 and every["false_alarms"] == 0
    text = confusion.markdown()
    assert "| moved | 2 | 0 | 0 | 0 |" in text and "| absent | 0 | 1 | 0 | 1 |" in text
    assert confusion.below({"accuracy": 0.5}) == ["accuracy 0.333 < 0.5"]
    with pytest.raises(KeyError, match=r"no bar 'f1' for an inspection \(known: accuracy, coverage, score\)"):
        confusion.below({"f1": 0.9})
    assert isinstance(confusion, Confusion) and Confusion().score == 0.0  # nothing judged scores 0


@pytest.mark.parametrize(("content", "message"), [
    ("{not json", "bad.json: line 1: not JSON"),
    ('{"objects": {}}', "bad.json: visits: missing: not an objrec-inspect report.json"),
    ('{"visits": 3}', "bad.json: visits: 3 is not a list"),
    ('{"visits": [{"expected": [{"name": "can", "status": "gone"}]}]}',
     "bad.json: visits[0].expected[0].status: 'gone' is not one of present, absent, moved, not_checked"),
    ('{"visits": [{"expected": [{"name": "can", "status": "present", "expected": {"x": 1}}]}]}',
     'bad.json: visits[0].expected[0].expected: {"x": 1} is not a position with x and y'),
    ('{"visits": [], "changes": ["can painted red"]}',
     "bad.json: changes[0]: 'can painted red' is neither 'NAME removed' nor 'NAME shifted by (DX, DY) m'"),
])
def test_a_report_that_cannot_be_scored_is_one_line_naming_file_and_field(tmp_path, content, message):
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    with pytest.raises(UserError) as caught:
        inspection_evaluation(parse("--inspection", str(bad), "--truth", str(WORLD)))
    assert str(caught.value).startswith(str(tmp_path))
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_world_that_does_not_hold_a_removed_object_is_refused(changed_report):
    with pytest.raises(UserError, match="no object or obstacle named 'unicorn'"):
        inspection_evaluation(parse("--inspection", str(changed_report), "--remove", "unicorn"))
    with pytest.raises(UserError, match=r"missing\.yaml"):
        inspection_evaluation(parse("--inspection", str(changed_report), "--truth", str(LAB / "missing.yaml")))


def test_objrec_eval_scores_a_report_and_guards_a_bar(changed_report, tmp_path, capsys):
    """The command line: --inspection alone writes report.json with the figures; against the unchanged world the
    three changes are false alarms, so --min-accuracy 0.9 exits 1 with one line per missed bar."""
    from objrec_apps.evaluate import main as evaluate_main

    out = tmp_path / "eval"
    assert evaluate_main(["--inspection", str(changed_report), "--out", str(out)]) == 0
    written = json.loads((out / "report.json").read_text())
    assert written["command"]["inspection"] == str(changed_report)
    assert "accuracy" in capsys.readouterr().out
    code = evaluate_main(["--inspection", str(changed_report), "--truth", str(WORLD), "--remove", "blue_ball",
                          "--min-accuracy", "0.9", "--out", str(tmp_path / "eval2")])
    err = capsys.readouterr().err
    assert code == 1 and "accuracy" in err
    assert evaluate_main(["--remove", "blue_ball", "--out", str(tmp_path / "eval3")]) == 2
    assert "only with --inspection" in capsys.readouterr().err
