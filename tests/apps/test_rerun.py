"""Rerun recordings of detection runs: written through a DetectionDirector, read back with rerun's own reader."""

from __future__ import annotations

import importlib.util
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pytest.importorskip("rerun")
from rerun.chunk import RrdReader  # noqa: E402

from objrec_apps.rerun_log import box_pose, open_rerun, quaternion_xyzw  # noqa: E402
from objrec_core import DetectionDirector, build_system, get_kind, open_source  # noqa: E402
from rerunio import RerunUnavailable  # noqa: E402

from ..rrd_rows import read_recording  # noqa: E402


def record(project_root: Path, params: str, spec: str, out: Path, keep_stages: bool = True):
    system = build_system(project_root / params)
    kind = get_kind(system.kind)
    seen = []
    director = DetectionDirector(system, keep_stages=keep_stages)
    director.add_annotation_sink(lambda frame, array, stages: seen.append((frame, array)))
    recorder = open_rerun(out, kind, system)
    director.add_annotation_sink(recorder)
    start = time.perf_counter()
    director.run_all(open_source(spec, kind.name))
    wall = time.perf_counter() - start
    recorder.close()
    return kind, seen, wall


def test_2d_demo_recording_holds_input_stages_polygons_and_scalars(project_root, tmp_path, capfd):
    out = tmp_path / "deep" / "run.rrd"  # missing folders are made
    kind, seen, wall = record(project_root, "params/hsv_demo.yaml", "demo:frames=3", out)
    assert capfd.readouterr().out == ""  # objrec-detect's stdout is its JSON
    rows = read_recording(out)
    assert {"/input/frame", "/input/detections", "/stages/colour/frame", "/stages/open/frame",
            "/stats/frame_seconds", "/stats/objects"} <= set(rows)
    assert not any(path.startswith("/stages/blobs") for path in rows)  # detectors are not filter outputs
    frames = [frame for frame, _ in seen]
    for path in ("/input/frame", "/stages/colour/frame", "/stages/open/frame", "/input/detections",
                 "/stats/frame_seconds", "/stats/objects"):
        assert [r["frame"] for r in rows[path]] == [0, 1, 2], path
        assert [r["stamp"] for r in rows[path]] == [round(f.stamp * 1e9) for f in frames], path

    for row, frame in zip(rows["/input/frame"], frames, strict=True):
        fmt = row["Image:format"][0]
        assert (fmt["width"], fmt["height"]) == (640, 480)
        assert np.array_equal(row["Image:buffer"][0], kind.preview(frame.data).ravel())
    assert rows["/stages/colour/frame"][0]["Image:format"][0]["width"] == 640

    for row, (_, array) in zip(rows["/input/detections"], seen, strict=True):
        outlines = kind.outlines(array)
        assert len(outlines) == 4
        assert row["LineStrips2D:labels"] == ["coloured_object"] * 4
        strips = row["LineStrips2D:strips"]
        assert len(strips) == 4
        for strip, outline in zip(strips, outlines, strict=True):
            strip = np.asarray(strip, dtype=np.float32)
            assert np.array_equal(strip[:-1], outline.polygon) and np.array_equal(strip[-1], outline.polygon[0])

    assert [r["Scalars:scalars"] for r in rows["/stats/objects"]] == [[4.0]] * 3
    seconds = [r["Scalars:scalars"][0] for r in rows["/stats/frame_seconds"]]
    assert all(s > 0 for s in seconds)
    assert sum(seconds) < wall  # the loop's time outside the recorder, within the run's wall time
    assert len(RrdReader(out).blueprints()) == 1  # the layout: input, each filter, the scalars


def test_without_stages_only_input_detections_and_scalars(project_root, tmp_path):
    out = tmp_path / "plain.rrd"
    record(project_root, "params/hsv_demo.yaml", "demo:frames=2", out, keep_stages=False)
    rows = read_recording(out)
    assert not any(path.startswith("/stages") for path in rows)
    assert len(rows["/input/frame"]) == len(rows["/input/detections"]) == len(rows["/stats/objects"]) == 2


def test_3d_demo_recording_holds_points_and_oriented_boxes(project_root, tmp_path, capfd):
    out = tmp_path / "cloud.rrd"
    kind, seen, _ = record(project_root, "params/shape_demo.yaml", "demo:frames=1", out)
    assert capfd.readouterr().out == ""
    rows = read_recording(out)
    assert rows["/"][0]["ViewCoordinates:xyz"] is not None  # x right, y down, z forward
    (frame, array), = seen

    row, = rows["/input/frame"]
    finite = np.isfinite(frame.data.points).all(axis=1)
    assert 10_000 < finite.sum() < len(finite)  # the demo cloud has holes, which are left out
    assert np.array_equal(row["Points3D:positions"], frame.data.points[finite])
    colours = np.asarray(row["Points3D:colors"], dtype=np.uint32)
    rgb = frame.data.colors[finite].astype(np.uint32)
    assert np.array_equal(colours, (rgb[:, 0] << 24) | (rgb[:, 1] << 16) | (rgb[:, 2] << 8) | 255)
    for stage in ("DistanceFilter", "PlaneRemovalFilter"):
        points = rows[f"/stages/{stage}/frame"][0]["Points3D:positions"]
        assert 0 < len(points) < finite.sum()  # each filter keeps fewer points

    boxes, = rows["/input/detections"]
    outlines = kind.outlines(array)
    assert boxes["Boxes3D:labels"] == [o.label for o in outlines] == ["cylinder", "sphere"]
    for centre, half, quaternion, outline in zip(boxes["Boxes3D:centers"], boxes["Boxes3D:half_sizes"],
                                                 boxes["Boxes3D:quaternions"], outlines, strict=True):
        rebuilt = corners_of(np.asarray(centre), np.asarray(half), np.asarray(quaternion))
        assert np.allclose(rebuilt, outline.box, atol=1e-5)
    assert rows["/stats/objects"][0]["Scalars:scalars"] == [2.0]


# -- box geometry -----------------------------------------------------------------------------------
def rotation_of(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def corners_of(centre: np.ndarray, half: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Corner i at -/+ half a side along local x, y, z by bits 2, 1, 0 of i (objrec_core.Outline)."""
    signs = np.array([[1 if i & 4 else -1, 1 if i & 2 else -1, 1 if i & 1 else -1] for i in range(8)])
    return centre + (signs * half) @ rotation_of(q).T


@pytest.mark.parametrize("half", [(0.3, 0.1, 0.05), (0.2, 0.2, 0.0)])  # a box, and a flat one
def test_box_pose_recovers_centre_sizes_and_rotation(half):
    rng = np.random.default_rng(7)
    for _ in range(50):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        centre = rng.uniform(-2, 2, 3)
        corners = corners_of(centre, np.array(half), q)
        got_centre, got_half, got_q = box_pose(corners)
        assert np.allclose(got_centre, centre) and np.allclose(got_half, half)
        assert np.allclose(corners_of(got_centre, got_half, got_q), corners, atol=1e-9)


def test_quaternion_of_half_turns_and_identity():
    assert np.allclose(quaternion_xyzw(np.eye(3)), [0, 0, 0, 1])
    for axis in range(3):
        rotation = -np.eye(3)
        rotation[axis, axis] = 1.0  # half a turn about this axis
        q = quaternion_xyzw(rotation)
        assert np.isclose(abs(q[axis]), 1.0) and np.allclose(np.delete(q, axis), 0.0)


def test_mirrored_corners_still_give_the_same_box():
    corners = corners_of(np.zeros(3), np.array([0.3, 0.2, 0.1]), np.array([0, 0, 0, 1.0]))
    mirrored = corners * np.array([1, 1, -1])  # a left-handed listing of the same box
    centre, half, q = box_pose(mirrored)
    assert np.allclose(half, [0.3, 0.2, 0.1])
    rebuilt = corners_of(centre, half, q)
    assert {tuple(np.round(c, 9)) for c in rebuilt} == {tuple(np.round(c, 9)) for c in mirrored}


# -- when a recording cannot be made ----------------------------------------------------------------
def test_without_rerun_sdk_the_error_names_the_extra(project_root, tmp_path, monkeypatch):
    system = build_system(project_root / "params/hsv_demo.yaml")
    monkeypatch.setitem(sys.modules, "rerun", None)  # `import rerun` now raises ImportError
    with pytest.raises(RerunUnavailable, match=r"rerun-sdk.*install objrec\[viz\]"):
        open_rerun(tmp_path / "x.rrd", get_kind("2d"), system)
    assert not (tmp_path / "x.rrd").exists()


def test_the_module_loads_without_rerun_sdk(monkeypatch):
    """objrec-detect imports it whether or not the extra is installed."""
    import objrec_apps.rerun_log as module

    monkeypatch.setitem(sys.modules, "rerun", None)
    spec = importlib.util.spec_from_file_location("rerun_log_without_sdk", module.__file__)
    fresh = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fresh)
    assert callable(fresh.open_rerun)
    import rerunio

    with pytest.raises(RerunUnavailable, match=r"rerun-sdk, which is not installed: install objrec\[viz\]"):
        rerunio.import_rerun()


@pytest.mark.parametrize(("target", "fragment"), [
    ("out.txt", "--rerun out.txt: give a file ending in .rrd, or spawn"),
    ("a_file/out.rrd", "a_file/out.rrd: cannot be written"),
])
def test_bad_targets_say_why(project_root, tmp_path, monkeypatch, target, fragment):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a_file").write_text("not a folder")
    with pytest.raises(RerunUnavailable) as caught:
        open_rerun(target, get_kind("2d"), build_system(project_root / "params/hsv_demo.yaml"))
    assert fragment in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the display check is for Linux")
def test_spawn_without_a_display_is_refused(project_root, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RerunUnavailable, match=r"no display.*--rerun out\.rrd"):
        open_rerun("spawn", get_kind("2d"), build_system(project_root / "params/hsv_demo.yaml"))


def test_objrec_detect_writes_the_recording_beside_its_json_lines(project_root, tmp_path):
    import json
    import subprocess

    out = tmp_path / "runs" / "hsv.rrd"  # a missing parent folder is made
    result = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", "params/hsv_demo.yaml", "-s", "demo:frames=3", "--rerun",
         str(out), "--annotate", str(tmp_path / "pictures")],
        capture_output=True, text=True, cwd=project_root, timeout=120,
    )
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert [len(line["objects"]) for line in lines] == [4, 4, 4]  # stdout holds only the JSON lines
    rows = read_recording(out)
    assert len(rows["/input/frame"]) == 3 and len(rows["/input/detections"]) == 3
    assert len(rows["/stages/colour/frame"]) == 3  # every filter stage is kept for the recording
    assert len(list((tmp_path / "pictures").glob("*.png"))) == 3
    bad = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", "params/hsv_demo.yaml", "-s", "demo:frames=1", "--rerun",
         str(tmp_path / "x.txt")], capture_output=True, text=True, cwd=project_root, timeout=120,
    )
    assert bad.returncode == 2 and "give a file ending in .rrd" in bad.stderr and "Traceback" not in bad.stderr
