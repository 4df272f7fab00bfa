"""objrec-detect --explain: why each detector found nothing, per frame, on stderr or in a side file, with the
detections written exactly as without it; and a detector that cannot detect refused before the run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from objrec2d import DemoScene, DetectedObject2D, ImageDetector, Polygon
from objrec2d.feature_detector import FeatureDetector
from objrec_apps import detect
from objrec_core import DetectionDirector, build_system, open_source, register_module
from objrec_core.directors import DetectorOutcome
from objrec_core.explain import NO_REASON
from objrec_core.registry import unregister_module

DETECT = [sys.executable, "-m", "objrec_apps.detect"]


# -- frames and files ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def frames(tmp_path_factory) -> Path:
    """A folder: the demo scene with its poster, a textured frame without it, a plain frame, the demo again."""
    folder = tmp_path_factory.mktemp("frames")
    scene = DemoScene(seed=0)
    noise = cv2.GaussianBlur((np.random.default_rng(1).random((480, 640)) * 255).astype(np.uint8), (5, 5), 0)
    pictures = [scene.render(0)[0], cv2.cvtColor(noise, cv2.COLOR_GRAY2BGR), np.full((480, 640, 3), 128, np.uint8),
                scene.render(5)[0]]
    for index, picture in enumerate(pictures):
        cv2.imwrite(str(folder / f"frame{index}.png"), picture)
    return folder


def image_file(tmp_path: Path, picture: np.ndarray, name: str = "frame.png") -> str:
    path = tmp_path / name
    cv2.imwrite(str(path), picture)
    return str(path)


def run_main(capsys, *args: str) -> tuple[int, str, str]:
    code = detect.main([*args, "--no-progress"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def reason_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("frame ")]


def expected_reasons(params: str | Path, source: str) -> list[tuple[int, str, str, str]]:
    """(frame, detector id, type, reason) for each detector that found nothing, read in this process from
    the pipeline's stages and the reason each stage's result carries: what --explain must write."""
    system = build_system(params)
    expected = []
    for seq, frame in enumerate(open_source(source, system.kind)):
        stages = system.process(frame.data, keep_stages=True).stages
        for stage in stages:
            if stage.role == "detector" and not stage.objects:
                reason = getattr(stage.objects, "reason", None)
                expected.append((seq, stage.id, stage.type_name, reason if reason is not None else NO_REASON))
    return expected


def as_text(expected: list[tuple[int, str, str, str]]) -> list[str]:
    return [f"frame {seq}: {detector} ({type_name}): {reason}" for seq, detector, type_name, reason in expected]


# -- the shipped detectors' reasons ----------------------------------------------------------------------------
def test_binary_detector_reasons_on_stderr_and_the_whole_frame_is_no_object(project_root, capsys, tmp_path):
    params = str(project_root / "params" / "hsv_demo.yaml")
    saturated = np.zeros((480, 640, 3), np.uint8)
    saturated[:] = (0, 0, 255)  # red everywhere: the colour filter lets the whole frame through
    specks = np.full((480, 640, 3), 90, np.uint8)
    cv2.rectangle(specks, (100, 100), (104, 104), (0, 0, 255), -1)  # outline 16 px, under min_contour_length 40
    cases = [
        (np.full((480, 640, 3), 128, np.uint8),
         "no blob: the mask has no non-zero pixel (the filters before let nothing through)"),
        (saturated, "1 blob, none kept: 1 covering more than max_area_fraction 0.9 of the image (smallest 100%)"),
        (specks, "1 blob, none kept: 1 shorter than min_contour_length 40 px (longest 16 px)"),
    ]
    for index, (picture, reason) in enumerate(cases):
        code, out, err = run_main(capsys, params, "-s", image_file(tmp_path, picture, f"{index}.png"), "--explain")
        assert code == 0, err
        assert json.loads(out)["objects"] == []  # the whole red frame was one object before
        assert reason_lines(err) == [f"frame 0: blobs (BinaryDetector): {reason}"]


def test_a_frame_where_the_detector_found_objects_writes_nothing(project_root, capsys):
    code, out, err = run_main(capsys, str(project_root / "params" / "hsv_demo.yaml"), "-s", "demo:frames=3",
                              "--explain")
    assert code == 0, err
    assert [len(json.loads(line)["objects"]) for line in out.splitlines()] == [4, 4, 4]
    assert reason_lines(err) == [] and "3 frames, 12 objects" in err


def test_feature_detector_reasons_on_frames_without_the_poster(project_root, capsys, frames):
    params = project_root / "params" / "feature_demo.yaml"
    expected = expected_reasons(params, str(frames))
    assert [seq for seq, *_ in expected] == [1, 2]  # the poster is found in frames 0 and 3, not in 1 and 2
    assert all(detector == "poster" and type_name == "FeatureDetector" for _, detector, type_name, _ in expected)
    textured, plain = (reason for *_, reason in expected)
    assert "matches" in textured and "min_matches is 10" in textured  # too few matches, with its numbers
    assert plain != NO_REASON
    code, out, err = run_main(capsys, str(params), "-s", str(frames), "--explain")
    assert code == 0, err
    assert [len(json.loads(line)["objects"]) for line in out.splitlines()] == [1, 0, 0, 1]
    assert reason_lines(err) == as_text(expected)


def test_shape_detector_reasons_when_its_window_is_empty(capsys, tmp_path):
    params = tmp_path / "far.yaml"
    params.write_text(
        "format_version: 1\nobject_name: shape\nkind: 3d\npipeline:\n"
        "- {type: DistanceFilter, id: window, parameters: {min_distance: 5.0, max_distance: 6.0, measure: z}}\n"
        "- {type: ShapeDetector, id: cylinder, parameters: {shape: cylinder, min_radius: 0.02, max_radius: 0.1}}\n"
    )
    expected = expected_reasons(params, "demo:frames=2")
    assert [(seq, detector) for seq, detector, *_ in expected] == [(0, "cylinder"), (1, "cylinder")]
    assert all(reason != NO_REASON for *_, reason in expected)  # it gives reasons: its own, not the generic line
    # ... and they come with its results alone: detecting leaves nothing of the frame on the detector.
    system = build_system(params)
    detector = system.module("cylinder")
    before = dict(vars(detector))
    for frame in open_source("demo:frames=2", system.kind):
        assert detector.detect(system.module("window").filter(frame.data)).reason
    assert vars(detector).keys() == before.keys()
    assert all(vars(detector)[name] is value for name, value in before.items())
    code, _out, err = run_main(capsys, str(params), "-s", "demo:frames=2", "--explain")
    assert code == 0, err
    assert reason_lines(err) == as_text(expected)  # its own reason where it gives one, else the generic line


# -- the generic parts, with tiny detectors of this test ---------------------------------------------------------
class Quiet(ImageDetector):
    """Finds nothing and gives no reason (a plain list)."""

    def detect(self, frame):
        return []


class Everywhere(ImageDetector):
    """Finds one object in every frame."""

    def detect(self, frame):
        return [DetectedObject2D(self.object_name, Polygon.from_xy([(0, 0), (4, 0), (4, 4)]))]


class Uncalibrated(ImageDetector):
    """Cannot detect until calibrated: its ``ready`` says so."""

    def ready(self):
        return "no calibration: calibrate it in objrec-define first"

    def detect(self, frame):
        raise AssertionError("a detector that is not ready must never run")


@pytest.fixture
def tiny_detectors():
    for cls in (Quiet, Everywhere, Uncalibrated):
        register_module(cls)
    yield
    for cls in (Quiet, Everywhere, Uncalibrated):
        unregister_module(cls.type_name)


def write_params(tmp_path: Path, *types: str) -> str:
    path = tmp_path / "tiny.yaml"
    pipeline = [{"type": t, "id": t.lower()} for t in types]
    path.write_text(yaml.safe_dump({"format_version": 1, "object_name": "thing", "kind": "2d", "pipeline": pipeline}))
    return str(path)


def test_a_detector_without_reasons_gets_the_generic_line_and_one_that_found_gets_none(
        tiny_detectors, capsys, tmp_path):
    params = write_params(tmp_path, "Quiet", "Everywhere")
    picture = image_file(tmp_path, np.full((48, 64, 3), 128, np.uint8))
    code, out, err = run_main(capsys, params, "-s", picture, "--explain")
    assert code == 0, err
    assert len(json.loads(out)["objects"]) == 1
    assert reason_lines(err) == ["frame 0: quiet (Quiet): no objects (this detector gives no reason)"]


def test_a_detector_that_is_not_ready_is_refused_before_the_run(tiny_detectors, capsys, tmp_path):
    params = write_params(tmp_path, "Everywhere", "Uncalibrated")
    code, out, err = run_main(capsys, params, "-s", "demo:frames=2")
    assert code == 2 and out == ""
    assert err == (f"objrec-detect: error: {params}: pipeline[1] (uncalibrated): Uncalibrated cannot detect: "
                   "no calibration: calibrate it in objrec-define first\n")


def test_outcomes_are_the_same_with_stages_kept_or_not(tiny_detectors, project_root):
    system = build_system(project_root / "params" / "hsv_demo.yaml")
    system.add_module(Quiet("quiet"))
    frame = next(iter(open_source("demo:frames=1", "2d")))
    heard: dict[bool, list] = {}
    for keep in (False, True):
        heard[keep] = []
        director = DetectionDirector(system, keep_stages=keep,
                                     outcome_sinks=[lambda _h, outcomes, k=keep: heard[k].extend(outcomes)])
        assert len(director.process(frame).objects) == 4
    assert heard[False] == heard[True] == [DetectorOutcome("blobs", "BinaryDetector", 4, None),
                                           DetectorOutcome("quiet", "Quiet", 0, None)]


# -- a feature file saved before a target was selected -----------------------------------------------------------
def feature_file_without_target(project_root: Path, tmp_path: Path) -> Path:
    data = yaml.safe_load((project_root / "params" / "feature_demo.yaml").read_text())
    del data["pipeline"][0]["state"]
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_a_feature_file_without_target_is_refused_at_start(project_root, tmp_path):
    path = feature_file_without_target(project_root, tmp_path)
    why = FeatureDetector().ready()
    result = subprocess.run([*DETECT, str(path), "-s", "demo:frames=3"], capture_output=True, text=True,
                            cwd=project_root, timeout=120)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == (
        f"objrec-detect: error: {path}: pipeline[0] (poster): FeatureDetector cannot detect: {why}\n")
    assert why.startswith("no target: select one in objrec-define")


def test_objrec_batch_refuses_a_feature_file_without_target_too(project_root, tmp_path):
    path = feature_file_without_target(project_root, tmp_path)
    result = subprocess.run([sys.executable, "-m", "objrec_apps.batch", str(path), "demo:frames=2",
                             "--out", str(tmp_path / "out")], capture_output=True, text=True, cwd=project_root,
                            timeout=120)
    assert result.returncode == 2 and result.stdout == ""
    assert f"{path}: pipeline[0] (poster): FeatureDetector cannot detect: no target" in result.stderr
    assert len(result.stderr.splitlines()) == 1 and not (tmp_path / "out").exists()


# -- outputs: unchanged detections, the side file, every output type, failures -----------------------------------
def test_the_real_command_writes_the_same_detections_with_and_without_explain(project_root, frames, tmp_path):
    params = str(project_root / "params" / "feature_demo.yaml")
    side = tmp_path / "reasons.jsonl"
    runs = [subprocess.run([*DETECT, params, "-s", str(frames), *extra], capture_output=True, cwd=project_root,
                           timeout=120) for extra in ([], ["--explain"], [f"--explain={side}"])]
    assert [r.returncode for r in runs] == [0, 0, 0], [r.stderr for r in runs]
    assert len(runs[0].stdout.splitlines()) == 4 and runs[1].stdout == runs[0].stdout == runs[2].stdout  # bytes
    assert len(reason_lines(runs[1].stderr.decode())) == 2
    assert reason_lines(runs[2].stderr.decode()) == []  # with a side file, stderr holds no reason
    assert len(side.read_text().splitlines()) == 2


def test_the_side_file_holds_one_json_line_per_reason_with_the_frame_s_seq_and_stamp(
        project_root, capsys, frames, tmp_path):
    params = project_root / "params" / "feature_demo.yaml"
    side = tmp_path / "deeper" / "reasons.jsonl"  # missing folders are made, as for --output
    code, out, _err = run_main(capsys, str(params), "-s", str(frames), f"--explain={side}", "--skip-empty")
    assert code == 0
    headers = {line["header"]["seq"]: line["header"] for line in map(json.loads, out.splitlines())}
    assert sorted(headers) == [0, 3]  # --skip-empty: only the frames with the poster
    written = [json.loads(line) for line in side.read_text().splitlines()]
    expected = expected_reasons(params, str(frames))
    assert [(r["seq"], r["detector"], r["type"], r["reason"]) for r in written] == expected
    assert all(set(r) == {"seq", "stamp", "detector", "type", "reason"} for r in written)
    stamps = {f.index: f.stamp for f in open_source(str(frames), "2d")}
    for r in written:
        assert r["stamp"]["secs"] + r["stamp"]["nsecs"] / 1e9 == pytest.approx(stamps[r["seq"]], abs=1e-6)


def test_a_bare_explain_before_the_parameter_file_does_not_take_it_as_its_path(project_root, capsys, tmp_path):
    picture = image_file(tmp_path, np.full((48, 64, 3), 128, np.uint8))
    code, _out, err = run_main(capsys, "--explain", str(project_root / "params" / "hsv_demo.yaml"), "-s", picture)
    assert code == 0, err
    assert reason_lines(err) == ["frame 0: blobs (BinaryDetector): no blob: the mask has no non-zero pixel "
                                 "(the filters before let nothing through)"]


def test_explain_works_with_a_typed_output(project_root, capsys, frames, tmp_path):
    pytest.importorskip("rosbags")
    side, recording = tmp_path / "reasons.jsonl", tmp_path / "out.mcap"
    params = project_root / "params" / "feature_demo.yaml"
    code, out, err = run_main(capsys, str(params), "-s", str(frames), "-o", str(recording), f"--explain={side}")
    assert code == 0, err
    assert out == "" and recording.stat().st_size > 0 and "4 messages" in err
    assert [json.loads(line)["seq"] for line in side.read_text().splitlines()] == [1, 2]


def test_a_side_file_that_cannot_be_written_is_one_line_and_exit_2(project_root, capsys, frames, tmp_path):
    params = str(project_root / "params" / "feature_demo.yaml")
    code, out, err = run_main(capsys, params, "-s", str(frames), "--explain=/dev/full")
    assert code == 2
    assert err == ("objrec-detect: error: /dev/full: cannot be written: No space left on device; "
                   "0 whole lines before it are kept\n")
    assert len(out.splitlines()) == 2  # the frame that failed is written to stdout before its reasons
    code, out, err = run_main(capsys, params, "-s", str(frames), f"--explain={tmp_path}")
    assert code == 2 and out == ""
    assert err == (f"objrec-detect: error: {tmp_path}: refused as --explain: it is a folder, not a regular file; "
                   "nothing was written\n")
    same = tmp_path / "both.jsonl"
    code, out, err = run_main(capsys, params, "-s", str(frames), "-o", str(same), f"--explain={same}")
    assert code == 2 and "the same file as --output" in err and len(err.splitlines()) == 1
    code, out, err = run_main(capsys, params, "-s", str(frames), "--explain=")
    assert (code, out) == (2, "") and err == ("objrec-detect: error: --explain=: give a path after the =, or "
                                              "--explain alone for the reasons on stderr\n")
