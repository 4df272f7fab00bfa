"""The 2D scorer: COCO AP/AR equal to pycocotools (the oracle) on generated sets and their edge cases,
precision/recall/F1 on a constructed case whose numbers are worked out by hand, the bars, the pictures, and
the shipped colour demo system scored on the demo's own truth."""

from __future__ import annotations

import contextlib
import io

import cv2
import numpy as np
import pytest
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

from objrec2d import DetectedObject2D, DetectedObject2DArray, HSVFilter, MorphologyFilter, Polygon
from objrec2d.evaluation import ImageEvaluation, ImageScorer, match_greedy
from objrec2d.evaluation_coco import STAT_NAMES
from objrec2d.truth import TruthObject2D, write_coco
from objrec_core import DetectionDirector, RecognitionSystem, get_kind, open_source
from objrec_core.evaluation import FrameTruth, TruthSet, labelled_frames, score
from objrec_core.storage import build_system


def rect(x: float, y: float, w: float, h: float) -> tuple[tuple[float, float], ...]:
    return ((x, y), (x + w, y), (x + w, y + h), (x, y + h))


def found(*objects: tuple[str, tuple[float, float, float, float]]) -> DetectedObject2DArray:
    return DetectedObject2DArray(objects=[DetectedObject2D(n, Polygon.from_xy(rect(*box))) for n, box in objects])


# -- the oracle -----------------------------------------------------------------------------------------------
def oracle(tmp_path, truth: TruthSet, detections: list[DetectedObject2DArray]) -> COCOeval:
    """pycocotools on the same input: the truth as objrec writes it, the detections as COCO results (box =
    the polygon's bounds, score 1.0, in the order objrec scores them)."""
    path = tmp_path / "truth.json"
    write_coco(path, truth, image_size=(640, 480))
    with contextlib.redirect_stdout(io.StringIO()):
        gt = COCO(str(path))
        ids = {c["name"]: c["id"] for c in gt.dataset["categories"]}
        results = []
        for frame, array in zip(truth.frames, detections, strict=True):
            for obj in array.objects:
                xy = np.array(obj.polygon.xy())
                x0, y0 = xy.min(axis=0)
                x1, y1 = xy.max(axis=0)
                results.append({"image_id": frame.index, "category_id": ids.get(obj.name, 999), "score": 1.0,
                                "bbox": [float(x0), float(y0), float(x1 - x0), float(y1 - y0)]})
        if results:
            dt = gt.loadRes(results)
        else:  # pycocotools' loadRes cannot take an empty list: an empty result set made by hand
            dt = COCO()
            dt.dataset = {"images": gt.dataset["images"], "categories": gt.dataset["categories"], "annotations": []}
            dt.createIndex()
        evaluation = COCOeval(gt, dt, "bbox")
        evaluation.evaluate()
        evaluation.accumulate()
        evaluation.summarize()
    return evaluation


def scored(truth: TruthSet, detections: list[DetectedObject2DArray], **options) -> ImageEvaluation:
    scorer = get_kind("2d").scorer(**options)
    for frame, array in zip(truth.frames, detections, strict=True):
        scorer.add(frame, array)
    return scorer.result()


def generated(seed: int, names=("red", "blue", "mug"), frames: int = 6, **edge: bool):
    """A random set: boxes of several names, detections jittered from them, duplicated, missed, spurious and
    tiny; ``edge``: ``no_truth``, ``no_detections``, ``crowded`` (over 100 detections on one frame)."""
    rng = np.random.default_rng(seed)
    truth, detections = [], []
    for index in range(frames):
        objects, found_here = [], []
        for name in names[: int(rng.integers(1, len(names) + 1))]:
            for _ in range(int(rng.integers(0, 4))):
                x, y, w, h = rng.uniform(0, 500), rng.uniform(0, 380), rng.uniform(0.5, 160), rng.uniform(0.5, 120)
                if rng.random() < 0.15:
                    w, h = rng.uniform(0.2, 3), rng.uniform(0.2, 3)  # tiny
                if rng.random() < 0.5:
                    objects.append(TruthObject2D(name, box=(x, y, w, h)))
                else:
                    outline = ((x, y), (x + w, y + h / 3), (x + w / 2, y + h), (x, y + h))
                    objects.append(TruthObject2D(name, outline))
                if rng.random() < 0.75:
                    box = (x + rng.normal(0, w / 8), y + rng.normal(0, h / 8), w * rng.uniform(0.75, 1.3),
                           h * rng.uniform(0.75, 1.3))
                    found_here.append((name, box))
                    if rng.random() < 0.2:
                        found_here.append((name, box))  # a duplicate
            for _ in range(int(rng.integers(0, 3))):
                found_here.append((name, (rng.uniform(0, 500), rng.uniform(0, 380), rng.uniform(1, 90),
                                          rng.uniform(1, 90))))
        if edge.get("crowded") and index == 1:
            found_here += [(names[0], (i * 4.0, 10.0, 30.0, 30.0)) for i in range(110)]
        if index == 2:
            found_here = []  # truth, nothing detected
        order = rng.permutation(len(found_here))
        truth.append(FrameTruth(index, None, () if edge.get("no_truth") else tuple(objects)))
        detections.append(found(*[found_here[i] for i in order]) if not edge.get("no_detections") else found())
    return TruthSet("2d", truth), detections


CASES = [(seed, {}) for seed in range(12)] + [
    (100, {"no_truth": True}), (101, {"no_detections": True}), (102, {"no_truth": True, "no_detections": True}),
    (103, {"crowded": True}), (104, {"names": ("only",)}), (105, {"frames": 1}),
]


@pytest.mark.parametrize(("seed", "edge"), CASES, ids=[f"{s}-{'-'.join(e) or 'random'}" for s, e in CASES])
def test_coco_ap_and_ar_equal_pycocotools_on_the_same_input(tmp_path, seed, edge):
    options = dict(edge)
    kwargs = {k: options.pop(k) for k in ("names", "frames") if k in options}
    truth, detections = generated(seed, **kwargs, **options)
    expected = oracle(tmp_path, truth, detections)
    # Given the truth's names, the figures are COCO's over every truth category, as pycocotools'.
    evaluation = scored(truth, detections, names=truth.names)
    assert np.abs(evaluation.coco.stats - expected.stats).max() <= 1e-6, (evaluation.coco.stats, expected.stats)
    if truth.names:  # (with no truth at all pycocotools has no category; objrec scores the detected names: -1)
        assert np.array_equal(evaluation.coco.precision, expected.eval["precision"])
    stats = evaluation.coco_stats()
    for name, value in zip(STAT_NAMES, expected.stats, strict=True):
        assert stats[name] == (None if value == -1 else pytest.approx(value, abs=1e-6)), name
    for k, row in enumerate(evaluation.summary_rows()[:-1] if truth.names else []):  # per name: COCO's category
        p = expected.eval["precision"][:, :, k, 0, 2]
        assert row["ap"] == (pytest.approx(float(np.mean(p[p > -1])), abs=1e-6) if (p > -1).any() else None)


def test_the_generated_sets_hold_the_edge_cases_they_claim():
    truth, detections = generated(103, crowded=True)
    assert max(len(a.objects) for a in detections) > 100
    assert len(detections[2].objects) == 0 and truth.frames[2].objects
    assert any(o.bbox[2] < 3 and o.bbox[3] < 3 for f in generated(4)[0] for o in f.objects)  # tiny boxes
    names = [o.name for a in generated(0)[1] for o in a.objects]
    assert len(set(names)) >= 2


def test_by_default_only_the_names_detected_are_scored_and_the_rest_is_listed():
    truth, detections = generated(7)
    detections = [DetectedObject2DArray(objects=[o for o in a.objects if o.name == "red"]) for a in detections]
    evaluation = scored(truth, detections)
    assert evaluation.names == ["red"]
    assert set(evaluation.unscored) == {"blue", "mug"}
    assert evaluation.unscored["blue"] == sum(o.name == "blue" for f in truth for o in f.objects)
    assert scored(truth, [found() for _ in detections]).names == ["blue", "mug", "red"]  # nothing found at all


# -- precision, recall, F1 -------------------------------------------------------------------------------------
def test_precision_recall_f1_on_a_case_worked_out_by_hand():
    truth = TruthSet("2d", [
        FrameTruth(0, None, (TruthObject2D("A", box=(0, 0, 10, 10)), TruthObject2D("B", box=(20, 0, 10, 10)))),
        FrameTruth(1, None, (TruthObject2D("A", rect(0, 0, 10, 10)),)),
        FrameTruth(2, None, ()),
    ])
    detections = [
        found(("A", (1, 0, 10, 10)), ("A", (50, 50, 5, 5))),  # IoU 90/110 = 0.82: a hit; a false positive
        found(("A", (5, 0, 10, 10))),  # IoU 50/150 = 0.33: a false positive and a miss
        found(("A", (0, 0, 3, 3))),  # nothing labelled here
    ]
    evaluation = scored(truth, detections, names=["A", "B"])
    rows = {r["name"]: r for r in evaluation.summary_rows()}
    assert {k: rows["A"][k] for k in ("truth", "detected", "tp", "fp", "fn")} == \
        {"truth": 2, "detected": 4, "tp": 1, "fp": 3, "fn": 1}
    assert rows["A"]["precision"] == 0.25 and rows["A"]["recall"] == 0.5
    assert rows["A"]["f1"] == pytest.approx(2 / (2 + 3 + 1))
    assert (rows["B"]["precision"], rows["B"]["recall"], rows["B"]["f1"]) == (None, 0.0, 0.0)
    assert (rows["all"]["tp"], rows["all"]["fp"], rows["all"]["fn"]) == (1, 3, 2)
    assert evaluation.score == rows["all"]["f1"] == pytest.approx(2 / (2 + 3 + 2))
    assert [(f["tp"], f["fp"], f["fn"]) for f in evaluation.to_dict()["per_frame"]] == [(1, 1, 1), (0, 1, 1),
                                                                                          (0, 1, 0)]
    # By default only A is scored (nothing is named B): B's truth is listed, not counted.
    default = scored(truth, detections)
    assert default.names == ["A"] and default.unscored == {"B": 1}
    assert default.score == pytest.approx(2 / (2 + 3 + 1))
    # Half the threshold: frame 1's detection is a hit now.
    assert scored(truth, detections, names=["A"], iou=0.3).summary_rows()[0]["tp"] == 2


def test_greedy_matching_takes_the_best_overlap_first_and_each_box_once():
    truth = np.array([[0, 0, 10, 10], [4, 0, 10, 10]], float)
    detected = np.array([[3, 0, 10, 10], [0, 0, 10, 10], [0, 0, 10, 10]], float)
    # detection 1 and truth 0 overlap fully; detection 0 then takes truth 1 (IoU 90/110); detection 2 is a duplicate
    assert match_greedy(truth, detected, 0.5) == [(1, 0), (0, 1)]
    assert match_greedy(truth, detected[:0], 0.5) == [] and match_greedy(truth[:0], detected, 0.5) == []


def test_a_detection_named_like_a_truth_group_matches_it():
    truth = TruthSet("2d", [FrameTruth(0, None, (TruthObject2D("red", rect(0, 0, 20, 20), group="coloured"),
                                                 TruthObject2D("target", box=(50, 50, 40, 40), group="poster")))])
    evaluation = scored(truth, [found(("coloured", (0, 0, 20, 20)))])
    assert evaluation.names == ["coloured"] and evaluation.score == 1.0 and evaluation.unscored == {"target": 1}
    assert evaluation.coco_stats()["ap"] == pytest.approx(1.0)


def test_nothing_to_find_and_nothing_found_is_perfect_and_undefined_figures_are_none():
    evaluation = scored(TruthSet("2d", [FrameTruth(0, None, ())]), [found()])
    assert evaluation.score == 1.0 and evaluation.frames == 1
    row = evaluation.summary_rows()[-1]
    assert (row["precision"], row["recall"], row["ap"]) == (None, None, None)
    assert evaluation.below({"precision": 0.5}) == ["precision n/a < 0.5 (nothing to measure it on)"]


def test_bars_name_what_they_miss_and_unknown_bars_are_refused():
    truth, detections = generated(3)
    evaluation = scored(truth, detections)
    f1 = evaluation.score
    assert evaluation.below({"f1": f1}) == []
    assert evaluation.below({"f1": 1.0, "recall": 0.0}) == [f"f1 {f1:.3f} < 1"]
    ap = evaluation.coco_stats()["ap"]
    assert evaluation.below({"ap": 0.999, "ap50": 0.0}) == [f"ap {ap:.3f} < 0.999"]
    with pytest.raises(KeyError, match="f1, precision, recall, ap, ap50"):
        evaluation.below({"centre_error": 0.1})


def test_the_report_holds_the_table_and_says_what_the_figures_mean():
    truth, detections = generated(5)
    evaluation = scored(truth, detections)
    report = evaluation.to_dict()
    assert report["kind"] == "2d" and report["frames"] == 6 and report["score"] == evaluation.score
    assert [r["name"] for r in report["rows"]] == [*evaluation.names, "all"]
    text = evaluation.markdown()
    assert "| name | truth | detected | tp | fp | fn | precision | recall | f1 | ap | ap50 | ap75 | ar |" in text
    assert f"**{evaluation.score:.3f}**" in text and "pycocotools" in text
    import json

    json.dumps(report)  # JSON-ready


# -- the demo ----------------------------------------------------------------------------------------------
def demo_labelled(frames: int, seed: int = 0):
    kind = get_kind("2d")
    source = list(open_source(f"demo:seed={seed},frames={frames}", "2d"))
    return TruthSet("2d", [kind.frame_truth(f) for f in source]), source


def test_the_shipped_colour_demo_system_scores_f1_1_on_the_demo_truth(project_root):
    """Measured: F1 1.000 (240 of 240 shapes, no false positive), AP@[.5:.95] 0.995, on 60 frames."""
    truth, source = demo_labelled(60)
    system = build_system(project_root / "objrec_apps" / "systems" / "hsv_demo.yaml")
    evaluation = score(system, get_kind("2d"), labelled_frames(source, truth))
    row = evaluation.summary_rows()[-1]
    assert evaluation.names == ["coloured_object"] and evaluation.unscored == {"target": 60}
    assert (row["truth"], row["tp"], row["fp"]) == (240, 240, 0)
    assert evaluation.score == 1.0
    assert row["ap50"] == 1.0 and row["ap"] > 0.99


def test_the_shipped_feature_demo_system_finds_the_poster_on_every_demo_frame(project_root):
    """Measured: F1 1.000 and AP@[.5:.95] 1.000 on 30 frames: the poster (truth ``target`` in the group
    ``poster``, the system's object name) found on each; the four shapes listed as not scored."""
    truth, source = demo_labelled(30)
    system = build_system(project_root / "objrec_apps" / "systems" / "feature_demo.yaml")
    evaluation = score(system, get_kind("2d"), labelled_frames(source, truth))
    assert evaluation.names == ["poster"] and evaluation.score == 1.0
    assert evaluation.unscored == {"blue": 30, "green": 30, "red": 30, "yellow": 30}
    assert evaluation.coco_stats()["ap"] > 0.95


def test_pictures_show_the_precision_recall_curve_and_the_worst_frames(tmp_path):
    truth, source = demo_labelled(20, seed=2)
    # Hue 100..179 and a loose saturation: the blue shape found, the green and yellow ones missed on every frame.
    system = RecognitionSystem([HSVFilter(h_min=100, h_max=179, s_min=60, v_min=40), MorphologyFilter(),
                                get_binary_detector()], object_name="coloured_object")
    evaluation = score(system, get_kind("2d"), labelled_frames(source, truth), worst=3)
    assert 0.2 <= evaluation.summary_rows()[-1]["recall"] <= 0.5
    written = evaluation.pictures(tmp_path / "pictures")
    assert [p.name for p in written] == ["pr_curve.png", "worst_frame_01.png", "worst_frame_02.png",
                                         "worst_frame_03.png"]
    curve = cv2.imread(str(written[0]))
    assert curve.shape == (600, 800, 3)
    worst = cv2.imread(str(written[1]))
    assert worst.shape == (480 + 28, 640, 3)
    assert (worst[:28] == 255).mean() > 0.8  # the title band
    # truth drawn green where the yellow triangle was missed: its outline's pixels are green in the picture
    frame = evaluation.worst_frames()[0]
    yellow = next(o for o in frame.truth if o.name == "yellow")
    x, y = np.round(yellow.polygon[0]).astype(int)
    patch = worst[28 + y - 2: 28 + y + 3, x - 2: x + 3].reshape(-1, 3)
    assert any(tuple(p) == (80, 230, 80) for p in patch)
    assert "worst_frame_01.png" in evaluation.markdown()


def get_binary_detector():
    from objrec2d import BinaryDetector

    return BinaryDetector()


def test_the_scorer_keeps_only_a_few_frames_pictures(tmp_path):
    truth, source = demo_labelled(12, seed=1)
    scorer = ImageScorer(worst=2)
    director = DetectionDirector(RecognitionSystem([HSVFilter(h_min=100, h_max=130, s_min=120, v_min=60),
                                                    MorphologyFilter(), get_binary_detector()], object_name="red"))
    for frame, label in labelled_frames(source, truth):
        scorer.add(label, director.process(frame), frame)
    kept = [r for r in scorer.result().records if r.image is not None]
    assert len(kept) == 2
    with pytest.raises(TypeError, match="TruthObject2D"):
        scorer.add(FrameTruth(0, None, ("not a 2D object",)), found())
    with pytest.raises(ValueError, match="iou"):
        ImageScorer(iou=0.0)
