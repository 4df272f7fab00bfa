"""objrec-detect --foxglove: a WebSocket client subscribes to a demo run and decodes, with the schemas the server
advertises, the input image or cloud, each filter's output, the detections drawn (image annotations, scene
entities) and the per-frame timing, and checks them against the JSON Lines of the same frames."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("foxglove")
pytest.importorskip("websockets")

from foxgloveio.server import parse_address
from objrec_apps.foxglove_view import DETECTIONS_TOPIC, INPUT_TOPIC, STAGE_TOPIC, TIMING_TOPIC, FoxgloveView
from objrec_apps.output_contract import RunEnd
from objrec_core import DetectionDirector, build_system, get_kind, open_source
from tests.foxglove_client import FoxgloveClient

ROOT = Path(__file__).resolve().parents[2]
#: A hang guard, never a timing assertion.
HANG_GUARD = 120


DETECT = "import sys; from objrec_apps.detect import main; sys.exit(main())"


def detect_main(argv: list[str]) -> int:
    from objrec_apps.detect import main

    return main(argv)


def stamp_key(stamp: dict) -> tuple[int, int]:
    """A JSON line's header stamp or a decoded foxglove Timestamp, as (seconds, nanoseconds)."""
    return (stamp["secs"], stamp["nsecs"]) if "secs" in stamp else (stamp["seconds"], stamp["nanos"])


def test_detect_serves_images_stages_annotations_and_timing_equal_to_the_json_lines():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    command = [sys.executable, "-c", DETECT, "params/hsv_demo.yaml", "--source", "demo:seed=3", "--max-frames",
               "100000", "--foxglove", "0", "--no-progress"]
    wanted = [INPUT_TOPIC, STAGE_TOPIC + "colour", STAGE_TOPIC + "open", DETECTIONS_TOPIC, TIMING_TOPIC]
    with subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True) as run:
        try:
            line = run.stderr.readline()
            assert "objrec-detect: Foxglove live view on ws://127.0.0.1:" in line, line + run.stderr.read()
            with FoxgloveClient(line.rsplit(" ", 1)[1].strip(), wanted) as client:
                assert client.wait_for(lambda c: all(len(c.messages(t)) >= 3 for t in wanted), HANG_GUARD), \
                    client.error
        finally:
            run.send_signal(signal.SIGTERM)
            out, err = run.communicate(timeout=HANG_GUARD)
    assert run.returncode == 0, err
    assert "frames served live to Foxglove" in err
    lines = {stamp_key(d["header"]["stamp"]): d for d in map(json.loads, out.splitlines())}
    assert {c.schema_name for c in client.subscriptions.values()} == {
        "foxglove.RawImage", "foxglove.ImageAnnotations", "objrec.FrameTiming"}

    # the input image: the demo's frame of the same index, pixel for pixel
    image = client.messages(INPUT_TOPIC)[0].message
    assert (image["width"], image["height"], image["encoding"], image["step"]) == (640, 480, "bgr8", 1920)
    assert image["frame_id"] == "camera"
    seq = lines[stamp_key(image["timestamp"])]["header"]["seq"]
    with open_source("demo:seed=3", "2d") as demo:
        frame = next(f for f in demo if f.index == seq)
    assert np.array_equal(np.frombuffer(image["data"], np.uint8).reshape(480, 640, 3), frame.data)
    for stage in ("colour", "open"):
        picture = client.messages(STAGE_TOPIC + stage)[0].message
        assert (picture["width"], picture["height"]) == (640, 480)
        assert len(picture["data"]) == picture["step"] * 480

    # the detections: one closed outline per object through its polygon's pixels, labelled with its name
    compared = 0
    for received in client.messages(DETECTIONS_TOPIC):
        annotations = received.message
        objects = lines[stamp_key(annotations["timestamp"])]["objects"]
        assert len(annotations["points"]) == len(objects) == len(annotations["texts"])
        for outline, text, obj in zip(annotations["points"], annotations["texts"], objects, strict=True):
            assert outline["type"] == 2  # LINE_LOOP: closed
            assert [(p["x"], p["y"]) for p in outline["points"]] == [(p["x"], p["y"]) for p in obj["polygon"]["points"]]
            assert text["text"] == obj["name"] == "coloured_object"
            assert (text["position"]["x"], text["position"]["y"]) == (
                min(p["x"] for p in obj["polygon"]["points"]), min(p["y"] for p in obj["polygon"]["points"]))
            compared += 1
    assert compared >= 3

    for received in client.messages(TIMING_TOPIC):
        timing = received.message
        line = lines[stamp_key({"secs": received.log_time // 10**9, "nsecs": received.log_time % 10**9})]
        assert timing["frame"] == line["header"]["seq"]
        assert timing["objects"] == len(line["objects"])
        assert timing["seconds"] > 0


def test_3d_detections_are_spheres_and_cylinders_where_the_objects_are(tmp_path):
    system = build_system(ROOT / "params/shape_demo.yaml")
    kind = get_kind(system.kind)
    director = DetectionDirector(system)
    found = []
    director.add_sink(found.append)
    view = FoxgloveView(parse_address("0"), kind, system, announce=io.StringIO())
    view.attach(director)
    topics = [INPUT_TOPIC, DETECTIONS_TOPIC, *(STAGE_TOPIC + m.id for m in system.filters)]
    try:
        with FoxgloveClient(view.server.url, topics) as client:
            channels = [view.sink.input, view.sink.detections, *view.sink.stages.values()]
            assert client.wait_for(lambda c: all(view.server.wanted(ch) for ch in channels), HANG_GUARD), client.error
            with open_source("demo:seed=3", "3d") as source:
                director.run_all(source, 1)
            assert client.wait_for(lambda c: all(c.messages(t) for t in topics), HANG_GUARD), client.error
    finally:
        view.close(RunEnd())
    cloud = client.messages(INPUT_TOPIC)[0].message
    assert cloud["point_stride"] == 16
    assert [(f["name"], f.get("offset", 0)) for f in cloud["fields"]] == [
        ("x", 0), ("y", 4), ("z", 8), ("red", 12), ("green", 13), ("blue", 14), ("alpha", 15)]
    points = np.frombuffer(cloud["data"], dtype=np.dtype([("xyz", "<f4", 3), ("rgba", "u1", 4)]))
    with open_source("demo:seed=3", "3d") as source:
        first = next(iter(source)).data
    finite = np.isfinite(first.points).all(axis=1)
    assert len(points) == int(finite.sum())
    assert np.array_equal(points["xyz"], first.points[finite].astype(np.float32))

    update = client.messages(DETECTIONS_TOPIC)[0].message
    assert update["deletions"][0]["type"] == 1  # ALL: the previous frame's objects go
    objects = [o.to_dict() for o in found[0].objects]
    assert {o["shape"] for o in objects} == {"sphere", "cylinder"}
    assert len(update["entities"]) == len(objects)
    for entity, obj in zip(update["entities"], objects, strict=True):
        assert entity["frame_id"] == "camera"
        solid = entity["spheres" if obj["shape"] == "sphere" else "cylinders"][0]
        position = obj["box"]["pose"]["position"]
        assert [solid["pose"]["position"][a] for a in "xyz"] == pytest.approx([position[a] for a in "xyz"])
        diameter = 2 * obj["radius"]
        assert [solid["size"][a] for a in "xy"] == pytest.approx([diameter, diameter])
        if obj["shape"] == "cylinder":
            assert solid["size"]["z"] == pytest.approx(obj["box"]["height"])
            q = solid["pose"]["orientation"]
            axis = _rotate((q["x"], q["y"], q["z"], q["w"]), (0.0, 0.0, 1.0))  # the primitive's axis
            b = obj["box"]["pose"]["orientation"]
            assert axis == pytest.approx(_rotate((b["x"], b["y"], b["z"], b["w"]), (0.0, 1.0, 0.0)), abs=1e-9)
        assert entity["texts"][0]["text"] == obj["name"]


def _rotate(q: tuple[float, float, float, float], v: tuple[float, float, float]) -> list[float]:
    x, y, z, w = q
    m = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    return list(m @ np.asarray(v))


def test_a_stalled_viewer_never_blocks_detection():
    """A client that subscribes to every channel and then reads nothing: every frame is still detected and
    offered to the view (counted, not timed); the viewer just loses messages."""
    system = build_system(ROOT / "params/hsv_demo.yaml")
    director = DetectionDirector(system)
    view = FoxgloveView(parse_address("0"), get_kind(system.kind), system, announce=io.StringIO())
    view.attach(director)
    frames = 150
    try:
        with FoxgloveClient(view.server.url, lambda topic: True, read=False) as stalled:
            channels = [view.sink.input, view.sink.detections, view.sink.timing, *view.sink.stages.values()]
            assert stalled.wait_for(lambda c: all(view.server.wanted(ch) for ch in channels), HANG_GUARD)
            worker = threading.Thread(target=lambda: director.run_all(open_source("demo:seed=3", "2d"), frames))
            worker.start()
            worker.join(HANG_GUARD)
            assert not worker.is_alive(), "detection blocked on a viewer that reads nothing"
            assert all(view.server.wanted(ch) for ch in channels)  # still connected, still subscribed
            assert director.stats.frames == view.sink.frames == frames
            stalled.read = True  # the viewer wakes up: it gets what its queue kept, the newest frame's last
            assert stalled.wait_for(lambda c: any(m.message["frame"] == frames - 1 for m in c.messages(TIMING_TOPIC)),
                                    HANG_GUARD), stalled.error
    finally:
        view.close(RunEnd())
    # ~4.6 MB a frame went to a socket nobody read: the oldest messages were dropped, not queued without bound
    received = len(stalled.messages(INPUT_TOPIC))
    assert 0 < received < frames


@pytest.mark.parametrize(("value", "why"), [
    ("70000", "--foxglove: port 70000 is above the maximum 65535"),
    ("host:", "--foxglove: 'host:': no port after the colon"),
    ("-1", "--foxglove: port -1 is below the minimum 0"),
    ("[::1", "--foxglove: '[::1': write an IPv6 host in brackets, [HOST]:PORT"),
])
def test_bad_foxglove_values_are_one_line_exit_2(capsys, value, why):
    with pytest.raises(SystemExit) as exc:
        detect_main(["params/hsv_demo.yaml", "--source", "demo", f"--foxglove={value}"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("objrec-detect: error: ") and why in err, err


def test_without_foxglove_sdk_the_error_names_the_extra(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "foxglove", None)  # as if not installed: importing it fails
    monkeypatch.chdir(ROOT)
    assert detect_main(["params/hsv_demo.yaml", "--source", "demo:frames=1", "--foxglove", "0"]) == 2
    out, err = capsys.readouterr()
    assert err == "objrec-detect: error: --foxglove needs the viz extra: pip install 'objrec[viz]'\n"
    assert out == ""


def test_host_and_port_forms():
    assert (parse_address("8765").host, parse_address("8765").port) == ("127.0.0.1", 8765)
    assert (parse_address("0.0.0.0:0").host, parse_address("0.0.0.0:0").port) == ("0.0.0.0", 0)
    assert (parse_address("[::1]:9000").host, parse_address("[::1]:9000").port) == ("::1", 9000)
    assert str(parse_address("[::1]:9000")) == "[::1]:9000"
    with pytest.raises(ValueError, match="IPv6 host in brackets"):
        parse_address("::1:9000")


# -- objrec-inspect ---------------------------------------------------------------------------------------
LAB = ROOT / "examples" / "inspection_lab"
MISSION, MAP, WORLD = LAB / "mission.yaml", LAB / "lab.yaml", LAB / "lab.world.yaml"


def test_inspection_serves_its_camera_frames_and_sightings_where_the_report_has_them(tmp_path):
    from objrec_apps.foxglove_inspection import CAMERA_TOPIC, SIGHTINGS_TOPIC, InspectionView
    from objrec_apps.inspection import open_inspection

    inspection = open_inspection(MISSION, MAP, WORLD, out_dir=tmp_path)
    view = InspectionView(parse_address("0"), inspection)
    topics = [CAMERA_TOPIC, SIGHTINGS_TOPIC, "/map", "/patrol/state"]
    try:
        with FoxgloveClient(view.url, topics) as client:
            assert client.wait_for(lambda c: all(view.patrol.server.wanted(ch) for ch in (view.camera, view.sightings)),
                                   HANG_GUARD), client.error
            inspection.run(time_limit=3600, handle_sigint=False)
            seen = [e for e in inspection.sim.events.events if e["type"] == "detection"]
            assert seen, "the example mission's detect tasks find its objects"
            assert client.wait_for(lambda c: c.messages(SIGHTINGS_TOPIC) and len(
                c.messages(SIGHTINGS_TOPIC)[-1].message["entities"]) == len(seen), HANG_GUARD), client.error
    finally:
        view.close()
    entities = client.messages(SIGHTINGS_TOPIC)[-1].message["entities"]
    for entity, event in zip(entities, seen, strict=True):
        assert entity["frame_id"] == "map"
        centre = entity["spheres"][0]["pose"]["position"]
        assert (centre["x"], centre["y"], centre["z"]) == pytest.approx((event["x"], event["y"], event["z"]))
        assert entity["texts"][0]["text"] == event["name"]
    found = {name for name, (_, verdict) in inspection.report.objects.items() if verdict.found is not None}
    assert {e["texts"][0]["text"] for e in entities} >= found
    frames = client.messages(CAMERA_TOPIC)
    assert frames, "every task's camera frame is served"
    camera = inspection.camera.params
    assert {(f.message["width"], f.message["height"], f.message["encoding"]) for f in frames} == {
        (camera.width, camera.height, "bgr8")}
    assert client.messages("/map") and client.messages("/patrol/state")[-1].message["states"] == ["SHUTDOWN"]


def test_objrec_inspect_foxglove_option(tmp_path, capsys):
    from objrec_apps.inspect import main as inspect_main

    args = [str(MISSION), "--map", str(MAP), "--world", str(WORLD), "--out", str(tmp_path / "out")]
    assert inspect_main([*args, "--foxglove", "127.0.0.1:0"]) == 0
    out, err = capsys.readouterr()
    assert err.startswith("objrec-inspect: Foxglove live view on ws://127.0.0.1:") and "report:" in out
    with pytest.raises(SystemExit) as exc:
        inspect_main([*args, "--foxglove", "70000"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err == "objrec-inspect: error: --foxglove: port 70000 is above the maximum 65535\n"


def test_objects_without_a_box_pose_are_drawn_as_their_outline_boxes():
    """A kind whose objects' JSON has no box pose: the kind's outline corners give each a cube (centre, sides and
    rotation recovered from the 8 corners), labelled as the kind labels it."""
    from types import SimpleNamespace

    from objrec3d.messages import OrientedBox, Point, Pose, Quaternion
    from objrec_apps.foxglove_scene import object_solids
    from objrec_core import Outline

    rotation = Quaternion.from_matrix([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 degrees about z
    box = OrientedBox(Pose(Point(1.0, 2.0, 3.0), rotation), 0.4, 0.2, 0.1)
    kind = SimpleNamespace(outlines=lambda objects: [Outline("thing (crate)", box=box.corners())])
    objects = SimpleNamespace(objects=[SimpleNamespace(to_dict=lambda: {"name": "thing"})])
    [(label, primitive, centre, orientation, size)] = object_solids(kind, objects)
    assert (label, primitive) == ("thing (crate)", "cube")
    assert centre == pytest.approx((1.0, 2.0, 3.0))
    assert size == pytest.approx((0.4, 0.2, 0.1))
    q = np.asarray(orientation) * np.sign(orientation[3])
    assert q == pytest.approx([rotation.x, rotation.y, rotation.z, rotation.w])
