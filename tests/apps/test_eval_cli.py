"""objrec-eval end to end: the figures it prints and writes are the library's Evaluation of the same frames,
whether it runs the system, scores saved JSON Lines or a saved MCAP file, or runs a batch on Dask; the bars
(exit 1), the user mistakes (one line, exit 2) and the pictures.

What is checked here is the command (that it prints, writes and judges exactly what the kind's Evaluation
says), not the kind's scoring, which the kinds' own tests check against pycocotools and synthetic scenes.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from objrec_apps import detect, evaluate
from objrec_core import build_system, get_kind, open_source
from objrec_core.evaluation import Evaluation, FrameTruth, TruthSet, score
from objrec_core.evaluation.run import score_saved

HSV = "params/hsv_demo.yaml"
SHAPE = "params/shape_demo.yaml"
DEMO = "demo:seed=3,frames=6"


# -- helpers ------------------------------------------------------------------------------------------------
def run_eval(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = evaluate.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def library_evaluation(params: str, spec: str) -> Evaluation:
    """What the library says of the same frames: the system run on each frame, scored by the kind."""
    system = build_system(params)
    kind = get_kind(system.kind)

    def frames() -> Iterator[tuple[Any, FrameTruth]]:
        with open_source(spec, kind.name) as source:
            for frame in source:
                label = kind.frame_truth(frame)
                assert label is not None
                yield frame, label

    return score(system, kind, frames())


def all_row(evaluation: Evaluation) -> dict[str, Any]:
    return next(r for r in evaluation.summary_rows() if r["name"] == "all")


def table_row(text: str, name: str) -> dict[str, str]:
    """The row ``name`` of a printed table, by its heading."""
    lines = [line for line in text.splitlines() if line.strip()]
    heading = lines[0].split()
    for line in lines[1:]:
        cells = line.split()
        if cells[0] == name:
            return dict(zip(heading, cells, strict=True))
    raise AssertionError(f"no row {name} in\n{text}")


def same_json(a: Any, b: Any) -> bool:
    """Equal as JSON (floats to 1e-12, NaN equal to null)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_json(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_json(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        if a is None or b is None:
            return (a is None and (b is None or math.isnan(b))) or (b is None and math.isnan(a))
        return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)
    return bool(a == b)


def reported(evaluation: Evaluation) -> Any:
    """An evaluation's figures as report.json holds them."""
    return json.loads(json.dumps(evaluation.to_dict(), default=lambda v: v.tolist()).replace("NaN", "null"))


# -- running the system -----------------------------------------------------------------------------------------
def test_the_hsv_demo_with_its_own_truth_gives_the_librarys_figures(capsys, tmp_path, project_root, monkeypatch):
    monkeypatch.chdir(project_root)
    out = tmp_path / "eval"
    code, printed, err = run_eval(capsys, HSV, "--source", DEMO, "--out", out)
    assert code == 0, err
    library = library_evaluation(HSV, DEMO)
    assert library.frames == 6
    expected = all_row(library)
    row = table_row(printed, "all")
    assert 0 < expected["ap"] <= 1 and 0 < expected["f1"] <= 1
    for figure in ("precision", "recall", "f1", "ap", "ap50", "ar"):  # as printed: three decimals
        assert float(row[figure]) == pytest.approx(expected[figure], abs=5e-4)
    report = json.loads((out / "report.json").read_text())
    command = report.pop("command")
    assert command["frames"] == 6 and command["source"] == DEMO and command["interrupted"] is False
    report.pop("bars"), report.pop("missed")
    assert same_json(report, reported(library))
    assert (out / "report.md").read_text().strip() == library.markdown().strip()
    assert f"score {library.score:.3f}" in err


def test_pictures_are_written_and_are_images(capsys, tmp_path, project_root, monkeypatch):
    monkeypatch.chdir(project_root)
    poor = tmp_path / "poor.yaml"  # only the most saturated objects: some frames have misses to show
    poor.write_text((project_root / HSV).read_text().replace("s_min: 120", "s_min: 230"))
    out = tmp_path / "eval"
    code, _, err = run_eval(capsys, poor, "--source", DEMO, "--out", out)
    assert code == 0, err
    pictures = sorted(out.glob("*.png"))
    assert pictures, sorted(p.name for p in out.iterdir())
    for path in pictures:
        image = cv2.imread(str(path))
        assert image is not None and image.ndim == 3, path
        height, width = image.shape[:2]
        assert height >= 100 and width >= 100, (path, image.shape)
        if "frame" in path.stem:  # a frame with its truth and detections: the demo frame, a title above it
            assert width == 640 and 480 <= height <= 560, (path, image.shape)
    names = {p.name for p in pictures}
    assert "pr_curve.png" in names and any("frame" in n for n in names), names
    markdown = (out / "report.md").read_text()
    assert all(f"({name})" in markdown for name in names)


# -- saved detections -------------------------------------------------------------------------------------------
@pytest.fixture
def saved(tmp_path, project_root, monkeypatch, capsys) -> dict[str, Path]:
    """The hsv demo's detections saved by objrec-detect as JSON Lines and as an MCAP file, and its truth file."""
    monkeypatch.chdir(project_root)
    files = {"jsonl": tmp_path / "saved" / "detections.jsonl", "mcap": tmp_path / "saved" / "detections.mcap"}
    for path in files.values():
        assert detect.main([HSV, "--source", DEMO, "--output", str(path)]) == 0
    capsys.readouterr()
    kind = get_kind("2d")
    with open_source(DEMO, "2d") as source:
        labels = [kind.frame_truth(frame) for frame in source]
    files["truth"] = tmp_path / "labels" / "demo.json"
    files["truth"].parent.mkdir()
    kind.write_truth(files["truth"], TruthSet("2d", [lb for lb in labels if lb is not None], "index"))
    return files


@pytest.mark.parametrize("form", ["jsonl", "mcap"])
def test_scoring_saved_detections_gives_the_same_figures_as_running(capsys, tmp_path, saved, form):
    pytest.importorskip("rosbags")
    library = library_evaluation(HSV, DEMO)
    # JSON Lines do not say their kind: the truth file does, a demo source (of either kind) does not
    for truth in (["--truth", saved["truth"]], ["--source", DEMO, *(["--kind", "2d"] if form == "jsonl" else [])]):
        out = tmp_path / f"eval-{form}-{truth[0][2:]}"
        code, printed, err = run_eval(capsys, saved[form], *truth, "--out", out, "--no-pictures")
        assert code == 0, err
        report = json.loads((out / "report.json").read_text())
        assert report["command"]["detections"] == str(saved[form])
        for key in ("command", "bars", "missed"):
            report.pop(key)
        assert same_json(report, reported(library)), (report, reported(library))
        row, expected = table_row(printed, "all"), all_row(library)
        assert float(row["f1"]) == pytest.approx(expected["f1"], abs=5e-4)
        assert not list(out.glob("*.png"))


def test_saved_json_lines_match_score_saved(capsys, tmp_path, saved):
    kind = get_kind("2d")
    truth = kind.read_truth(saved["truth"])
    arrays = [kind.object_array_type.from_json(line) for line in saved["jsonl"].read_text().splitlines()]
    library = score_saved(kind, arrays, truth)
    code, _, err = run_eval(capsys, saved["jsonl"], "--truth", saved["truth"], "--kind", "2d", "--out", tmp_path / "e")
    assert code == 0, err
    assert f"score {library.score:.3f}" in err


def test_lines_left_out_by_skip_empty_count_as_frames_with_nothing_found(capsys, caplog, tmp_path, saved):
    lines = [json.loads(line) for line in saved["jsonl"].read_text().splitlines()]
    assert [line["header"]["seq"] for line in lines] == list(range(6))
    for line in lines[1:4:2]:
        line["objects"] = []  # frames 1 and 3: nothing found
    full, skipped = tmp_path / "full.jsonl", tmp_path / "skipped.jsonl"
    full.write_text("".join(json.dumps(line) + "\n" for line in lines))
    skipped.write_text("".join(json.dumps(line) + "\n" for line in lines if line["objects"]))
    reports = []
    for path in (full, skipped):
        caplog.clear()
        code, _, err = run_eval(capsys, path, "--truth", saved["truth"], "--out", tmp_path / path.stem, "--no-pictures")
        assert code == 0, err
        assert ("2 frames without detections were left out" in caplog.text) is (path == skipped), caplog.text
        report = json.loads((tmp_path / path.stem / "report.json").read_text())
        reports.append({k: v for k, v in report.items() if k != "command"})
    assert reports[0] == reports[1]
    assert reports[0]["frames"] == 6


# -- bars --------------------------------------------------------------------------------------------------------
def test_a_bar_above_the_figure_exits_1_with_one_line_per_bar(capsys, tmp_path, project_root, monkeypatch):
    monkeypatch.chdir(project_root)
    f1 = all_row(library_evaluation(HSV, DEMO))["f1"]
    assert 0 < f1 < 1 or f1 == 1.0
    code, _, err = run_eval(capsys, HSV, "--source", DEMO, "--out", tmp_path / "a", "--min-f1", "1.01",
                            "--min-recall", "0")
    assert code == evaluate.BELOW_BAR, err
    bar_lines = [line for line in err.splitlines() if "below the bar" in line]
    assert len(bar_lines) == 1 and "f1" in bar_lines[0] and "1.01" in bar_lines[0]
    report = json.loads((tmp_path / "a" / "report.json").read_text())
    assert report["bars"] == {"f1": 1.01, "recall": 0.0} and len(report["missed"]) == 1
    code, _, err = run_eval(capsys, HSV, "--source", DEMO, "--out", tmp_path / "b", "--min-f1", f"{f1 * 0.99}")
    assert code == 0, err
    assert "below the bar" not in err


def test_a_bar_the_kind_does_not_know_is_one_line(capsys, tmp_path, project_root, monkeypatch):
    monkeypatch.chdir(project_root)
    code, _, err = run_eval(capsys, HSV, "--source", DEMO, "--out", tmp_path / "a", "--max-centre-error", "0.05")
    assert code == 2
    assert err.count("\n") == 1 and "--max-centre-error" in err and "2d" in err
    assert not (tmp_path / "a").exists()


# -- user mistakes: one line, exit 2 ------------------------------------------------------------------------------
def one_line_error(code: int, err: str) -> str:
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("objrec-eval: error: "), err
    return lines[0]


def test_a_bad_truth_file_is_one_line(capsys, tmp_path, project_root, monkeypatch):
    monkeypatch.chdir(project_root)
    bad = tmp_path / "bad.json"
    bad.write_text('{"images": [}')
    line = one_line_error(*run_eval(capsys, HSV, "--source", DEMO, "--truth", bad, "--out", tmp_path / "o")[::2])
    assert str(bad) in line
    missing = tmp_path / "missing.json"
    line = one_line_error(*run_eval(capsys, HSV, "--source", DEMO, "--truth", missing, "--out", tmp_path / "o")[::2])
    assert str(missing) in line and "does not exist" in line


def test_an_output_folder_that_is_or_holds_an_input_is_refused(capsys, tmp_path, project_root, monkeypatch, saved):
    monkeypatch.chdir(project_root)
    truth = saved["truth"]
    line = one_line_error(*run_eval(capsys, HSV, "--source", DEMO, "--truth", truth, "--out", truth.parent)[::2])
    assert "truth file" in line and str(truth) in line
    line = one_line_error(*run_eval(capsys, saved["jsonl"], "--truth", truth, "--out", saved["jsonl"].parent)[::2])
    assert "detections" in line
    line = one_line_error(*run_eval(capsys, project_root / HSV, "--source", DEMO, "--out", project_root / "params")
                          [::2])
    assert "parameter file" in line
    folder = tmp_path / "frames"
    folder.mkdir()
    with open_source(DEMO, "2d") as source:
        for frame in source:
            cv2.imwrite(str(folder / f"{frame.index:03d}.png"), frame.data)
    line = one_line_error(*run_eval(capsys, HSV, "--source", folder, "--truth", truth, "--out", folder / "eval")[::2])
    assert "source" in line
    before = truth.read_bytes()
    assert truth.read_bytes() == before and sorted(p.name for p in folder.iterdir())[-1] == "005.png"


def test_other_mistakes_are_one_line(capsys, tmp_path, project_root, monkeypatch, saved):
    monkeypatch.chdir(project_root)
    out = ["--out", tmp_path / "o"]
    folder = tmp_path / "frames"
    folder.mkdir()
    cv2.imwrite(str(folder / "000.png"), np.full((48, 64, 3), 128, np.uint8))
    cases = {
        "--source": run_eval(capsys, HSV, *out),
        "truth": run_eval(capsys, saved["jsonl"], *out),
        "no end": run_eval(capsys, HSV, "--source", "demo", *out),
        "unknown": run_eval(capsys, saved["jsonl"], "--truth", saved["truth"], "--kind", "4d", *out),
        "--truth-dir": run_eval(capsys, HSV, "--source", DEMO, "--truth-dir", tmp_path, *out),
        "no truth of their own": run_eval(capsys, HSV, "--source", folder, *out),
    }
    for needle, (code, _, err) in cases.items():
        assert needle in one_line_error(code, err)
    bad_lines = tmp_path / "bad.jsonl"
    bad_lines.write_text(saved["jsonl"].read_text().splitlines()[0] + "\n[1, 2]\n")
    line = one_line_error(*run_eval(capsys, bad_lines, "--truth", saved["truth"], "--kind", "2d", *out)[::2])
    assert str(bad_lines) in line and "line 2" in line


# -- 3D ----------------------------------------------------------------------------------------------------------
def test_the_shape_demo_with_its_own_truth(capsys, tmp_path, project_root, monkeypatch):
    monkeypatch.chdir(project_root)
    spec = "demo:seed=1,frames=2"
    out = tmp_path / "eval3d"
    code, printed, err = run_eval(capsys, SHAPE, "--source", spec, "--out", out, "--max-centre-error", "10")
    assert code == 0, err
    library = library_evaluation(SHAPE, spec)
    report = json.loads((out / "report.json").read_text())
    for key in ("command", "bars", "missed"):
        report.pop(key)
    assert same_json(report, reported(library))
    assert float(table_row(printed, "all")["f1"]) == pytest.approx(all_row(library)["f1"], abs=5e-4)
    pictures = sorted(out.glob("*.png"))
    assert pictures
    for path in pictures:
        image = cv2.imread(str(path))
        assert image is not None and min(image.shape[:2]) >= 100, path
    code, _, err = run_eval(capsys, SHAPE, "--source", spec, "--out", out, "--min-ap", "0.5")
    assert "--min-ap" in one_line_error(code, err)


# -- a batch on Dask ----------------------------------------------------------------------------------------------
def _recorder(project_root: Path) -> Any:
    import importlib.util

    spec = importlib.util.spec_from_file_location("record_demo_bag", project_root / "scripts" / "record_demo_bag.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_batch_over_two_recordings_scores_each_and_all(capsys, tmp_path, project_root, monkeypatch):
    pytest.importorskip("rosbags")
    pytest.importorskip("distributed")
    monkeypatch.chdir(project_root)
    recorder, kind = _recorder(project_root), get_kind("2d")
    truth_dir = tmp_path / "labels"
    truth_dir.mkdir()
    seeds = {"first.bag": 1, "second": 2}  # a ROS 1 bag and a ROS 2 bag folder
    specs = {}
    for name, seed in seeds.items():
        path = tmp_path / "recordings" / name
        path.parent.mkdir(exist_ok=True)
        recorder.record(path, 4, ["2d"], seed)
        specs[name] = f"demo:seed={seed},frames=4"
        with open_source(specs[name], "2d") as source:
            labels = [kind.frame_truth(frame) for frame in source]
        kind.write_truth(truth_dir / f"{Path(name).stem}.json", TruthSet("2d", labels, "index"))
    out = tmp_path / "batch"
    recordings = [tmp_path / "recordings" / name for name in seeds]
    code, printed, err = run_eval(capsys, HSV, *recordings, "--truth-dir", truth_dir, "--out", out, "--workers", "2")
    assert code == 0, err
    each = {name: library_evaluation(HSV, spec) for name, spec in specs.items()}
    combined = kind.scorer()
    system = build_system(HSV)
    for spec in specs.values():
        with open_source(spec, "2d") as source:
            for frame in source:
                combined.add(kind.frame_truth(frame), evaluate_frame(system, frame), None)
    expected = combined.result()
    assert expected.frames == 8
    report = json.loads((out / "report.json").read_text())
    assert [row["status"] for row in report["batch"]] == ["ok", "ok"]
    for name, recording in zip(seeds, recordings, strict=True):
        assert same_json(report["recordings"][str(recording)], reported(each[name]))
        own = json.loads((out / "recordings" / Path(name).stem / "report.json").read_text())
        own.pop("command")
        assert same_json(own, reported(each[name]))
        assert (out / "detections" / f"{Path(name).stem}.jsonl").is_file()
    for key in ("command", "recordings", "batch", "bars", "missed"):
        report.pop(key)
    assert same_json(report, reported(expected))
    tables = printed.split("\n\n")
    assert float(table_row(tables[1], "all")["f1"]) == pytest.approx(all_row(expected)["f1"], abs=5e-4)
    assert len([line for line in tables[0].splitlines() if "recordings" in line]) == 2


def evaluate_frame(system: Any, frame: Any) -> Any:
    from objrec_core import DetectionDirector

    return DetectionDirector(system).process(frame)


# -- Ctrl-C --------------------------------------------------------------------------------------------------------
def test_ctrl_c_writes_the_report_of_the_frames_scored_so_far(tmp_path, project_root):
    import re
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "eval"
    command = [sys.executable, "-m", "objrec_apps.evaluate", HSV, "--source", "demo:frames=100000", "--out", str(out),
               "--progress"]
    child = subprocess.Popen(command, cwd=project_root, stderr=subprocess.PIPE, stdout=subprocess.PIPE)
    assert child.stderr is not None
    seen = b""
    deadline = time.monotonic() + 120  # a hang guard only
    counted = re.compile(rb"\| *([3-9]|[1-9][0-9]+)/100000")  # the bar has counted three scored frames or more
    while not counted.search(seen) and time.monotonic() < deadline:
        byte = child.stderr.read(1)
        if not byte:
            break
        seen += byte
    assert counted.search(seen), seen.decode(errors="replace")
    child.send_signal(signal.SIGINT)
    stdout, rest = child.communicate(timeout=120)
    err = (seen + rest).decode()
    assert child.returncode == 0, err
    report = json.loads((out / "report.json").read_text())
    assert report["command"]["interrupted"] is True
    assert 3 <= report["command"]["frames"] < 100000
    assert report["frames"] == report["command"]["frames"]
    assert "interrupted" in err and b"all" in stdout


def test_a_batch_of_demo_scenes_scores_their_own_truth_and_a_missing_label_file_is_one_line(capsys, tmp_path,
                                                                                            project_root, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.chdir(project_root)
    specs = ["demo:seed=1,frames=3", "demo:seed=2,frames=3"]
    out = tmp_path / "batch"
    code, printed, err = run_eval(capsys, HSV, *specs, "--out", out, "--workers", "1", "--min-f1", "1.01")
    assert code == evaluate.BELOW_BAR, err
    assert [table_row(printed, spec)["status"] for spec in specs] == ["ok", "ok"]
    report = json.loads((out / "report.json").read_text())
    assert report["frames"] == 6 and len(report["missed"]) == 1
    for spec in specs:
        assert same_json(report["recordings"][spec], reported(library_evaluation(HSV, spec)))
    assert "below the bar: f1" in err
    labels = tmp_path / "labels"
    labels.mkdir()
    line = one_line_error(*run_eval(capsys, HSV, tmp_path / "a.bag", "--truth-dir", labels, "--out", out)[::2])
    assert "no label file a.*" in line
