"""2D ground truth in COCO JSON: what is written reads back equal, COCO tools read it, every malformed field is
refused in one line naming file, JSON path and value, and the demo writes the truth of the frames it produced."""

from __future__ import annotations

import contextlib
import copy
import io
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pycocotools.coco import COCO

from objrec2d import DemoSource
from objrec2d import truth as truth_module
from objrec2d.truth import TruthFileError, TruthObject2D, read_coco, truth_from_demo, write_coco
from objrec_core import SourceError, get_kind, open_source
from objrec_core.evaluation import FrameTruth, TruthSet
from strictio import InputError


def sample_truth() -> TruthSet:
    square = ((10.0, 20.0), (60.0, 20.0), (60.0, 70.0), (10.0, 70.0))
    return TruthSet("2d", [
        FrameTruth(0, None, (TruthObject2D("red", ((1.5, 2.25), (30.0, 2.0), (15.0, 40.125)), group="coloured"),
                             TruthObject2D("box", box=(100.0, 120.5, 40.0, 30.25)))),
        FrameTruth(3, None, ()),  # labelled: nothing here
        FrameTruth(7, None, (TruthObject2D("red", square, group="coloured", parts=(((70.0, 70.0), (80.0, 70.0),
                                                                                    (75.0, 80.0)),)),
                             TruthObject2D("mug", square, box=(9.0, 19.0, 52.0, 52.0)))),
    ])


def test_written_truth_reads_back_equal_and_cocos_own_reader_sees_the_same_objects(tmp_path):
    truth = sample_truth()
    path = tmp_path / "labels.json"
    write_coco(path, truth, image_size=(640, 480))
    back = read_coco(path)
    assert back.frames == truth.frames
    assert (back.keyed_by, back.path, back.names, back.indices) == ("index", str(path), ["box", "mug", "red"],
                                                                    [0, 3, 7])
    with contextlib.redirect_stdout(io.StringIO()):
        coco = COCO(str(path))
    assert sorted(c["name"] for c in coco.loadCats(coco.getCatIds())) == ["box", "mug", "red"]
    assert sorted(coco.getImgIds()) == [0, 3, 7] and coco.imgs[3]["width"] == 640
    red = coco.loadAnns(coco.getAnnIds(imgIds=[7], catIds=coco.getCatIds(catNms=["red"])))[0]
    assert red["bbox"] == [10.0, 20.0, 70.0, 60.0] and len(red["segmentation"]) == 2  # square and its part
    assert red["area"] == pytest.approx(50 * 50 + 50)  # the square and the triangle part
    assert coco.loadCats(red["category_id"])[0]["supercategory"] == "coloured"
    # the kind reads and writes the same files
    kind = get_kind("2d")
    kind.write_truth(tmp_path / "again.json", back)
    assert kind.read_truth(tmp_path / "again.json").frames == truth.frames
    assert kind.truth_format == "COCO JSON (.json)"


def test_truth_keyed_by_stamp_and_by_image_id_read_as_such(tmp_path):
    stamped = TruthSet("2d", [FrameTruth(None, 1_700_000_000_123_456_789, (TruthObject2D("a", box=(1, 2, 3, 4)),)),
                              FrameTruth(None, 1_700_000_000_223_456_789, ())], "stamp")
    write_coco(tmp_path / "s.json", stamped)
    back = read_coco(tmp_path / "s.json")
    assert back.keyed_by == "stamp" and back.frames == stamped.frames
    assert back.lookup(99, 1_700_000_000_223_456_789) is not None and back.lookup(0, None) is None
    # a labelling tool's export: image ids count the frames, no objrec field
    tool = {"images": [{"id": 2, "file_name": "b.png"}, {"id": 0, "file_name": "a.png"}],
            "categories": [{"id": 5, "name": "candy", "supercategory": ""}],
            "annotations": [{"id": 1, "image_id": 2, "category_id": 5, "bbox": [1, 2, 3, 4], "attributes": {}}],
            "info": {"tool": "CVAT"}, "licenses": []}
    (tmp_path / "tool.json").write_text(json.dumps(tool))
    back = read_coco(tmp_path / "tool.json")
    assert back.keyed_by == "index" and back.indices == [0, 2]
    assert back.lookup(2).objects == (TruthObject2D("candy", box=(1.0, 2.0, 3.0, 4.0)),)
    assert back.lookup(0).objects == ()


def good_document() -> dict:
    return {"images": [{"id": 0, "frame_index": 0}, {"id": 1, "frame_index": 1}],
            "categories": [{"id": 1, "name": "red"}, {"id": 2, "name": "blue"}],
            "annotations": [{"id": 1, "image_id": 0, "category_id": 1, "bbox": [1, 2, 3, 4],
                             "segmentation": [[0, 0, 5, 0, 5, 5]]}]}


def change(path: str, value: object):
    """A mutation setting the JSON path ``a.b[0].c`` to value (``...`` deletes it)."""
    def apply(doc: dict) -> dict:
        keys = [int(k) if k.isdigit() else k for k in path.replace("[", ".").replace("]", "").split(".")]
        here = doc
        for key in keys[:-1]:
            here = here[key]
        if value is ...:
            del here[keys[-1]]
        else:
            here[keys[-1]] = value
        return doc
    return apply


MALFORMED = [
    # (mutation, the JSON path named, words of the rule)
    (change("images", ...), "images", "missing"),
    (change("images", {}), "images", "expected a list"),
    (change("annotations", None), "annotations", "expected a list"),
    (change("categories[0].name", ""), "categories[0].name", "must not be empty"),
    (change("categories[0].name", 7), "categories[0].name", "expected text"),
    (change("categories[1].name", "red"), "categories[1].name", "a second category of this name"),
    (change("categories[1].id", 1), "categories[1].id", "a second category with this id"),
    (change("categories[0].id", "1"), "categories[0].id", "expected an integer"),
    (change("images[1].id", 0), "images[1].id", "a second image with this id"),
    (change("images[1].frame_index", 0), "images[1].frame_index", "images[0] labels the same frame"),
    (change("images[1].frame_index", -1), "images[1].frame_index", "out of range"),
    (change("images[1].frame_index", 1.5), "images[1].frame_index", "expected an integer"),
    (change("images[1].frame_index", ...), "images[1]", "names its frame by id"),
    (change("images[0]", []), "images[0]", "expected a mapping"),
    (change("annotations[0].image_id", 9), "annotations[0].image_id", "no image has this id"),
    (change("annotations[0].category_id", 9), "annotations[0].category_id", "no category has this id"),
    (change("annotations[0].image_id", ...), "annotations[0].image_id", "missing"),
    (change("annotations[0].bbox", [1, 2, 3]), "annotations[0].bbox", "expected [x, y, width, height]"),
    (change("annotations[0].bbox", [1, 2, -3, 4]), "annotations[0].bbox[2]", "out of range"),
    (change("annotations[0].bbox", [1, "2", 3, 4]), "annotations[0].bbox[1]", "expected a number"),
    (change("annotations[0].bbox", [1, True, 3, 4]), "annotations[0].bbox[1]", "expected a number"),
    (change("annotations[0].segmentation", [[0, 0, 5, 0, 5]]), "annotations[0].segmentation[0]", "flat list"),
    (change("annotations[0].segmentation", [[0, 0, 5, 0]]), "annotations[0].segmentation[0]", "3 points or more"),
    (change("annotations[0].segmentation", [[0, 0, 5, 0, 5, None]]), "annotations[0].segmentation[0][5]",
     "expected a number"),
    (change("annotations[0].segmentation", {"counts": "abc", "size": [4, 4]}), "annotations[0].segmentation",
     "RLE mask"),
    (change("annotations[0].iscrowd", 1), "annotations[0].iscrowd", "crowd regions are not supported"),
    (lambda d: change("annotations[0].segmentation", [])(change("annotations[0].bbox", ...)(d)), "annotations[0]",
     "needs a bbox or a segmentation"),
]


@pytest.mark.parametrize(("mutate", "where", "rule"), MALFORMED, ids=[f"{m[1]}:{m[2]}" for m in MALFORMED])
def test_every_malformed_field_is_refused_in_one_line_naming_file_path_and_value(tmp_path, mutate, where, rule):
    path = tmp_path / "labels.json"
    path.write_text(json.dumps(mutate(copy.deepcopy(good_document()))))
    with pytest.raises(TruthFileError) as caught:
        read_coco(path)
    text = str(caught.value)
    assert isinstance(caught.value, InputError) and "\n" not in text
    assert text.startswith(f"{path}: {where}: "), text
    assert rule in text, text


@pytest.mark.parametrize(("content", "rule"), [
    ('{"images": [], "images": [], "categories": [], "annotations": []}', 'duplicate key "images"'),
    ('{"images": [], "categories": [], "annotations": [{"bbox": [NaN, 1, 2, 3]}]}', "NaN is not a number JSON"),
    ('{"images": [], "categories": [], "annotations": [{"bbox": [1e999, 1, 2, 3]}]}', "too large a number"),
    ('{"images": [', "not valid JSON: Expecting value"),
    ("[1, 2]", "expected a COCO document"),
    ('{"images": [], "categories": [], "annotations": [' + "[" * 40 + "]" * 40 + "]}", "nested deeper than 32"),
    ("[" * 100000 + "]" * 100000, "nested too deeply"),
    ('{"images": [{"id": 1' + "0" * 5000 + "}]}", "not valid JSON"),
])
def test_broken_json_is_refused_in_one_line(tmp_path, content, rule):
    path = tmp_path / "labels.json"
    path.write_text(content)
    with pytest.raises(TruthFileError) as caught:
        read_coco(path)
    assert str(caught.value).startswith(f"{path}") and rule in str(caught.value) and "\n" not in str(caught.value)


def test_a_label_file_over_the_size_cap_or_not_a_file_is_refused(tmp_path, monkeypatch):
    path = tmp_path / "labels.json"
    path.write_text(json.dumps(good_document()))
    monkeypatch.setattr(truth_module, "MAX_TRUTH_BYTES", 100)
    with pytest.raises(InputError, match="over the limit of 100 bytes"):
        read_coco(path)
    with pytest.raises(InputError, match="is a folder"):
        read_coco(tmp_path)
    with pytest.raises(InputError, match="file not found"):
        read_coco(tmp_path / "missing.json")


def test_writing_is_atomic_and_refuses_two_groups_for_one_name(tmp_path):
    path = tmp_path / "labels.json"
    write_coco(path, sample_truth())
    before = path.read_bytes()
    clash = TruthSet("2d", [FrameTruth(0, None, (TruthObject2D("red", box=(0, 0, 1, 1), group="a"),
                                                 TruthObject2D("red", box=(0, 0, 1, 1), group="b")))])
    with pytest.raises(ValueError, match="two groups"):
        write_coco(path, clash)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["labels.json"]  # no temporary left


def test_the_demo_writes_the_truth_of_every_frame_it_produced_equal_to_frame_truth(tmp_path):
    path = tmp_path / "demo.json"
    kind = get_kind("2d")
    with open_source(f"demo:seed=3,frames=12,truth={path}", "2d") as source:
        frames = list(source)
    assert path.exists()
    truth = read_coco(path)
    assert truth.indices == list(range(12)) and truth.keyed_by == "index"
    assert truth.names == ["blue", "green", "red", "target", "yellow"]
    for frame in frames:
        label = truth.lookup(frame.index)
        assert label == kind.frame_truth(frame) == truth_from_demo(frame.truth, frame.index)
        shapes = {o.name: o for o in label.objects}
        for drawn in frame.truth["objects"]:
            assert np.array_equal(np.array(shapes[drawn["name"]].polygon), np.array(drawn["polygon"]))
            assert shapes[drawn["name"]].group == "coloured_object"
        assert np.array_equal(np.array(shapes["target"].polygon), np.array(frame.truth["target"]["corners"]))
    with contextlib.redirect_stdout(io.StringIO()):
        assert COCO(str(path)).imgs[11]["width"] == 640


def test_an_endless_demo_saves_its_truth_when_closed(tmp_path):
    path = tmp_path / "demo.json"
    source = DemoSource(truth=path)
    for frame in source:
        if frame.index == 4:
            break
    assert not path.exists()
    source.close()
    assert read_coco(path).indices == [0, 1, 2, 3, 4]
    with pytest.raises(SourceError, match="does not exist"):
        DemoSource(truth=tmp_path / "no" / "such.json")


def test_frames_not_from_the_demo_have_no_truth_of_their_own():
    from objrec_core import Frame

    assert get_kind("2d").frame_truth(Frame(np.zeros((4, 4, 3), np.uint8))) is None


def test_truth_objects_need_a_name_and_an_outline_or_a_box():
    with pytest.raises(ValueError, match="needs a name"):
        TruthObject2D("")
    with pytest.raises(ValueError, match="needs a box or a polygon"):
        TruthObject2D("a", ((0.0, 0.0), (1.0, 1.0)))
    obj = TruthObject2D("a", ((0.0, 0.0), (4.0, 0.0), (4.0, 3.0)), group="g")
    assert obj.bbox == (0.0, 0.0, 4.0, 3.0) and obj.area == 6.0
    assert obj.matches("a") and obj.matches("g") and not obj.matches("b")
    assert not TruthObject2D("a", box=(0, 0, 1, 1)).matches("")


def test_paths_are_shown_as_given(tmp_path):
    path = Path(tmp_path) / "sub dir"
    path.mkdir()
    (path / "x.json").write_text("{}")
    with pytest.raises(TruthFileError, match=r"sub dir/x\.json: images: missing"):
        read_coco(path / "x.json")


JSON_TOKENS = ["{", "}", "[", "]", ",", ":", '"', "null", "true", "-1", "0", "1e999", "NaN", "-Infinity", "9" * 5000,
               "1.5", '"x"', "[[]]", "{}", "\x00", "\\u0000", '"id": 0', '"bbox": [0, 0, -1, 1]', '"iscrowd": 1',
               '"segmentation": {"counts": "x"}', '"frame_index": 0', '"stamp_ns": 5', "[" * 60]


@st.composite
def mutated_coco(draw: st.DrawFn) -> str:
    """A valid label file with one to four edits: a JSON token inserted, a span deleted or a span duplicated."""
    text = json.dumps(good_document())
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        edit = draw(st.sampled_from(["insert", "delete", "repeat"]))
        if edit == "insert":
            text = text[:at] + draw(st.sampled_from(JSON_TOKENS)) + text[at:]
        else:
            end = min(len(text), at + draw(st.integers(1, 12)))
            text = text[:at] + (text[at:end] * 2 if edit == "repeat" else "") + text[end:]
    return text


@settings(max_examples=300, deadline=None, database=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=mutated_coco())
def test_fuzzed_label_files_read_or_are_refused_as_a_user_error(tmp_path, text):
    path = tmp_path / "fuzzed.json"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        truth = read_coco(path)
    except TruthFileError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(path))
        return
    assert all(isinstance(o, TruthObject2D) for f in truth for o in f.objects)


def test_a_label_file_that_is_not_utf8_is_refused_like_a_bad_field(tmp_path):
    path = tmp_path / "latin1.json"
    path.write_bytes(b'{"images": [], "categories": [{"id": 1, "name": "caf\xe9"}], "annotations": []}')
    with pytest.raises(TruthFileError, match=r"latin1\.json: is not utf-8 text"):
        read_coco(path)
