"""The 3D label file: shapes per frame round-trip exactly, every malformed field is refused with its line, and the
3D demo writes the truth of the frames it produced."""

from __future__ import annotations

import math

import pytest

from declare.fields import DocumentError
from objrec3d.truth import (
    SHAPE_FIELDS,
    TruthShape,
    demo_truth_shapes,
    parse_truth,
    read_truth,
    schema_rows,
    truth_text,
    write_truth,
)
from objrec_core import get_kind, open_source
from objrec_core.evaluation import FrameTruth, TruthSet

HEAD = "format: objrec-truth-3d\nversion: 1\n"


def sample_set() -> TruthSet:
    box = TruthShape("crate", "box", (0.3, 0.25, 1.1), size=(0.2, 0.1, 0.15),
                     orientation=(0.0, 0.0, math.sin(0.2), math.cos(0.2)), id="crate-1", visible_points=812)
    can = TruthShape("can", "cylinder", (-0.12, 0.31, 0.93), 0.04, (0.0, -0.6, -0.8), 0.12)
    ball = TruthShape("ball", "sphere", (0.14, 0.29, 0.96), 0.06, visible_points=0)
    return TruthSet("3d", [FrameTruth(0, None, (can, ball)), FrameTruth(4, None, ()),
                           FrameTruth(7, None, (box, can))])


def test_round_trip_is_exact(tmp_path) -> None:
    truth = sample_set()
    path = tmp_path / "labels.yaml"
    write_truth(path, truth)
    back = read_truth(path)
    assert back.frames == truth.frames
    assert back.keyed_by == "index" and back.path == str(path) and back.kind == "3d"
    assert back.names == ["ball", "can", "crate"]
    assert back.lookup(4).objects == () and back.lookup(5) is None
    write_truth(tmp_path / "again.yaml", back)
    assert (tmp_path / "again.yaml").read_text() == path.read_text()


def test_stamp_keyed_round_trip(tmp_path) -> None:
    shapes = (TruthShape("ball", "sphere", (0.0, 0.0, 1.0), 0.05),)
    truth = TruthSet("3d", [FrameTruth(None, 1_700_000_000_123_456_789, shapes), FrameTruth(3, 1_700_000_001_0, ())],
                     keyed_by="stamp")
    back = parse_truth(truth_text(truth))
    assert back.keyed_by == "stamp"
    assert back.lookup(99, 1_700_000_000_123_456_789).objects == shapes
    assert back.frames == truth.frames


def test_demo_truth_round_trips_over_many_scenes() -> None:
    from objrec3d.demo import demo_scene

    frames = [FrameTruth(i, None, demo_truth_shapes(demo_scene(seed, i)[1])) for i, seed in enumerate(range(6))]
    truth = TruthSet("3d", frames)
    assert parse_truth(truth_text(truth)).frames == frames
    cylinder = frames[0].objects[0]
    assert cylinder.name == "cylinder" and cylinder.shape == "cylinder" and cylinder.radius == pytest.approx(0.04)
    assert math.isclose(sum(a * a for a in cylinder.axis), 1.0)


def test_axis_and_quaternion_are_normalised() -> None:
    truth = parse_truth(HEAD + "frames:\n  - index: 0\n    objects:\n"
                        "      - {name: c, shape: cylinder, centre: [0, 0, 1], radius: 0.05, height: 0.1,"
                        " axis: [0, 0, 2]}\n"
                        "      - {name: b, shape: box, centre: [0, 0, 1], size: [1, 1, 1], orientation: [0, 0, 0, 3]}\n"
                        "      - {name: b2, shape: box, centre: [0, 0, 1], size: [1, 2, 3]}\n")
    cyl, box, plain = truth.frames[0].objects
    assert cyl.axis == (0.0, 0.0, 1.0)
    assert box.orientation == (0.0, 0.0, 0.0, 1.0) and plain.orientation == (0.0, 0.0, 0.0, 1.0)
    assert plain.size == (1.0, 2.0, 3.0) and plain.scale == 0.5


OBJ = "frames:\n  - index: 0\n    objects:\n      - "
MALFORMED = [
    # (text after the head, line, key path, what the message says)
    (OBJ + "{name: a, shape: sphere, centre: [0, 0, 1], radius: -1}\n", 6, "frames[0].objects[0].radius",
     "-1 is invalid: out of range"),
    (OBJ + "{name: a, shape: sphere, centre: [0, 0, 1], radius: .nan}\n", 6, "frames[0].objects[0].radius", "nan"),
    (OBJ + "{name: a, shape: cube, centre: [0, 0, 1], radius: 1}\n", 6, "frames[0].objects[0].shape",
     "'cube' is invalid: one of sphere, cylinder, box"),
    (OBJ + "{name: a, centre: [0, 0, 1], radius: 1}\n", 6, "frames[0].objects[0].shape", "missing"),
    (OBJ + "{shape: sphere, centre: [0, 0, 1], radius: 1}\n", 6, "frames[0].objects[0].name", "missing"),
    (OBJ + "{name: ' ', shape: sphere, centre: [0, 0, 1], radius: 1}\n", 6, "frames[0].objects[0].name",
     "must not be empty"),
    (OBJ + "{name: a, shape: sphere, centre: [0, 0, 1], radius: 1, axis: [0, 0, 1]}\n", 6,
     "frames[0].objects[0].axis", "unknown key"),
    (OBJ + "{name: a, shape: sphere, centre: [0, 0], radius: 1}\n", 6, "frames[0].objects[0].centre",
     "expected [x, y, z]"),
    (OBJ + "{name: a, shape: sphere, centre: [0, 0, x], radius: 1}\n", 6, "frames[0].objects[0].centre[2]",
     "'x' is invalid"),
    (OBJ + "{name: a, shape: sphere, centre: [0, 0, 1]}\n", 6, "frames[0].objects[0].radius", "missing"),
    (OBJ + "{name: a, shape: cylinder, centre: [0, 0, 1], radius: 1, height: 1}\n", 6,
     "frames[0].objects[0].axis", "missing"),
    (OBJ + "{name: a, shape: cylinder, centre: [0, 0, 1], radius: 1, height: 0, axis: [0, 0, 1]}\n", 6,
     "frames[0].objects[0].height", "0 is invalid"),
    (OBJ + "{name: a, shape: cylinder, centre: [0, 0, 1], radius: 1, height: 1, axis: [0, 0, 0]}\n", 6,
     "frames[0].objects[0].axis", "must not be zero"),
    (OBJ + "{name: a, shape: box, centre: [0, 0, 1], size: [1, 1, 1], orientation: [0, 0, 0, 0]}\n", 6,
     "frames[0].objects[0].orientation", "must not be zero"),
    (OBJ + "{name: a, shape: box, centre: [0, 0, 1], size: [1, -1, 1]}\n", 6, "frames[0].objects[0].size[1]",
     "out of range"),
    (OBJ + "{name: a, shape: box, centre: [0, 0, 1], radius: 1, size: [1, 1, 1]}\n", 6,
     "frames[0].objects[0].radius", "unknown key"),
    (OBJ + "{name: a, shape: sphere, centre: [0, 0, 1], radius: 1, visible_points: -3}\n", 6,
     "frames[0].objects[0].visible_points", "out of range"),
    (OBJ + "[1, 2]\n", 6, "frames[0].objects[0]", "expected a mapping"),
    ("frames:\n  - index: 0\n  - index: 0\n", 5, "frames[1].index", "frames[0] has it already"),
    ("frames:\n  - index: -1\n", 4, "frames[0].index", "out of range"),
    ("frames:\n  - objects: []\n", 4, "frames[0].index", "missing (the file is keyed by index)"),
    ("keyed_by: stamp\nframes:\n  - index: 0\n", 5, "frames[0].stamp_ns", "missing (the file is keyed by stamp)"),
    ("keyed_by: time\n", 3, "keyed_by", "'time' is invalid"),
    ("frames:\n  - index: 0\n    object: []\n", 5, "frames[0].object", "unknown key"),
    ("frames: {}\n", 3, "frames", "expected a list"),
]


@pytest.mark.parametrize(("body", "line", "where", "says"), MALFORMED, ids=[m[2] + ":" + m[3][:20] for m in MALFORMED])
def test_malformed_field_is_one_line_naming_file_line_field_and_value(tmp_path, body, line, where, says) -> None:
    path = tmp_path / "labels.yaml"
    path.write_text(HEAD + body)
    with pytest.raises(DocumentError) as caught:
        read_truth(path)
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith(f"{path}:{line}: {where}: "), text
    assert says in text, text


@pytest.mark.parametrize(("head", "where", "says"), [
    ("version: 1\nframes: []\n", "format", "missing"),
    ("format: coco\nversion: 1\n", "format", "'coco' is invalid"),
    ("format: objrec-truth-3d\nversion: 2\n", "version", "2 is invalid"),
    ("format: objrec-truth-3d\nversion: 1\nextra: 1\n", "extra", "unknown key"),
])
def test_malformed_head(tmp_path, head, where, says) -> None:
    path = tmp_path / "labels.yaml"
    path.write_text(head)
    with pytest.raises(DocumentError, match=f"{where}: .*{says}"):
        read_truth(path)


def test_not_yaml_and_missing_file(tmp_path) -> None:
    with pytest.raises(DocumentError, match="label file not found"):
        read_truth(tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text(HEAD + "frames: [\n")
    with pytest.raises(DocumentError, match=str(bad)):
        read_truth(bad)


def test_schema_rows_come_from_the_field_tables() -> None:
    rows = {name: (shapes, what) for name, shapes, what in schema_rows()}
    assert set(rows) == {name for record in SHAPE_FIELDS.values() for name in record.fields}
    assert rows["radius"][0] == "sphere, cylinder" and "(required)" in rows["radius"][1]
    assert rows["axis"][0] == "cylinder" and rows["size"][0] == "box" and rows["name"][0] == "all"


def test_cloud_kind_reads_and_writes_truth(tmp_path) -> None:
    kind = get_kind("3d")
    assert kind.truth_format
    kind.write_truth(tmp_path / "t.yaml", sample_set())
    assert kind.read_truth(tmp_path / "t.yaml").frames == sample_set().frames


def test_demo_source_writes_the_truth_of_its_frames(tmp_path) -> None:
    path = tmp_path / "demo-truth.yaml"
    kind = get_kind("3d")
    with open_source(f"demo:seed=4,frames=3,truth={path}", "3d") as source:
        own = [kind.frame_truth(frame) for frame in source]
    written = read_truth(path)
    assert [f.index for f in written.frames] == [0, 1, 2]
    assert written.frames == own
    assert [s.name for s in own[0].objects] == ["cylinder", "sphere"]


def test_endless_demo_writes_its_truth_when_closed(tmp_path) -> None:
    path = tmp_path / "endless.yaml"
    source = open_source(f"demo:seed=1,truth={path}", "3d")
    frames = iter(source)
    for _ in range(2):
        next(frames)
    assert not path.exists()
    source.close()
    assert read_truth(path).indices == [0, 1]


def test_demo_truth_into_a_missing_folder_is_refused(tmp_path) -> None:
    from objrec_core import SourceError

    with pytest.raises(SourceError, match="does not exist"):
        open_source(f"demo:truth={tmp_path}/no/such/t.yaml", "3d")


def test_frame_truth_of_sources_other_than_the_demo() -> None:
    from objrec_core import Frame

    kind = get_kind("3d")
    plain = [{"name": "ball", "shape": "sphere", "centre": [0.0, 0.0, 1.0], "radius": 0.1, "visible_points": 40}]
    truth = kind.frame_truth(Frame(None, index=3, truth=plain, stamp_ns=7))
    assert truth == FrameTruth(3, 7, (TruthShape("ball", "sphere", (0.0, 0.0, 1.0), 0.1, visible_points=40),))
    assert kind.frame_truth(Frame(None, truth=truth)) is truth
    assert kind.frame_truth(Frame(None)) is None
