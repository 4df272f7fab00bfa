"""The 3D scorer: errors equal the offsets built into synthetic detections, shape-type confusion is counted,
hidden shapes are not misses, identity switches and IDF1 match a hand count, and the shape demo scores on its
own truth."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from objrec3d import DetectedObject3D, DetectedObject3DArray, OrientedBox, Point, PointCloud, Pose, Quaternion
from objrec3d.evaluation import ShapeEvaluation, ShapeScorer
from objrec3d.evaluation_match import Gate, match_frame, visible_counts, visible_points
from objrec3d.tracking_score import TrackingScore
from objrec3d.truth import TruthShape
from objrec_core import build_system, get_kind, open_source
from objrec_core.evaluation import FrameTruth, TruthSet, score, score_saved


def rotation_with_y(axis) -> np.ndarray:
    y = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    x = np.cross(y, [0.0, 0.0, 1.0] if abs(y[2]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    return np.stack([x, y, np.cross(x, y)], axis=1)


def detected(name: str, shape: str, centre, radius: float, axis=(0.0, 0.0, 1.0), ident: str = "") -> DetectedObject3D:
    q = Quaternion.from_matrix(rotation_with_y(axis))
    box = OrientedBox(Pose(Point(*map(float, centre)), q), 2 * radius, 0.1, 2 * radius)
    return DetectedObject3D(name, box, shape, radius, 300, ident)


def array(*objects: DetectedObject3D) -> DetectedObject3DArray:
    return DetectedObject3DArray(objects=list(objects))


def tilted(axis, degrees: float) -> np.ndarray:
    """``axis`` turned by ``degrees`` about a perpendicular."""
    a = np.asarray(axis, dtype=float)
    p = np.cross(a, [1.0, 0.0, 0.0])
    p /= np.linalg.norm(p)
    t = math.radians(degrees)
    return math.cos(t) * a + math.sin(t) * p


CAN = TruthShape("can", "cylinder", (-0.1, 0.2, 1.0), 0.04, (0.0, -0.6, -0.8), 0.12)
BALL = TruthShape("ball", "sphere", (0.2, 0.2, 1.2), 0.06)


def test_errors_equal_the_known_offsets() -> None:
    scorer = ShapeScorer(min_visible=0)
    offsets = [0.004, 0.010, 0.020]  # centre offsets, metres
    radius_offsets = [0.001, -0.002, 0.003]
    tilts = [2.0, 5.0, 10.0]  # degrees
    for off, dr, tilt in zip(offsets, radius_offsets, tilts, strict=True):
        can = detected("can", "cylinder", np.add(CAN.centre, (off, 0.0, 0.0)), CAN.radius + dr, tilted(CAN.axis, tilt))
        ball = detected("ball", "sphere", np.add(BALL.centre, (0.0, 0.0, -off)), BALL.radius - dr)
        scorer.add(FrameTruth(0, None, (CAN, BALL)), array(ball, can))
    result = scorer.result()
    assert result.score == 1.0 and result.frames == 3
    can, ball = result.names["can"], result.names["ball"]
    assert (can.tp, can.fp, can.fn) == (3, 0, 0)
    np.testing.assert_allclose(can.errors["centre_error"], offsets, atol=1e-9)
    np.testing.assert_allclose(ball.errors["centre_error"], offsets, atol=1e-9)
    np.testing.assert_allclose(can.errors["radius_error"], radius_offsets, atol=1e-12)
    np.testing.assert_allclose(ball.errors["radius_error"], [-d for d in radius_offsets], atol=1e-12)
    np.testing.assert_allclose(can.errors["axis_error"], tilts, atol=1e-6)
    assert ball.errors["axis_error"] == []
    stats = result.to_dict()["names"]["can"]["centre_error"]
    assert stats["median"] == pytest.approx(0.010) and stats["max"] == pytest.approx(0.020)
    assert stats["p90"] == pytest.approx(0.010 + 0.8 * 0.010)  # linear percentile between 0.010 and 0.020
    assert result.to_dict()["all"]["radius_error"]["median"] == pytest.approx(0.002)


def test_axis_sign_does_not_matter() -> None:
    scorer = ShapeScorer(min_visible=0)
    flipped = detected("can", "cylinder", CAN.centre, CAN.radius, np.negative(CAN.axis))
    scorer.add(FrameTruth(0, None, (CAN,)), array(flipped))
    assert scorer.result().names["can"].errors["axis_error"] == [pytest.approx(0.0, abs=1e-6)]


def test_gate_is_five_centimetres_or_half_the_radius() -> None:
    gate = Gate()
    small = TruthShape("s", "sphere", (0.0, 0.0, 1.0), 0.04)
    large = TruthShape("l", "sphere", (1.0, 0.0, 1.0), 0.3)
    assert gate.of(small) == 0.05 and gate.of(large) == 0.15
    near = detected("s", "sphere", (0.0, 0.0, 1.049), 0.04)
    far = detected("s", "sphere", (0.0, 0.0, 1.051), 0.04)
    assert len(match_frame([small], [near], gate).pairs) == 1
    assert match_frame([small], [far], gate).pairs == ()
    assert len(match_frame([large], [detected("l", "sphere", (1.0, 0.14, 1.0), 0.3)], gate).pairs) == 1


def test_matching_prefers_the_same_name_and_is_one_to_one() -> None:
    a = TruthShape("a", "sphere", (0.0, 0.0, 1.0), 0.05)
    b = TruthShape("b", "sphere", (0.03, 0.0, 1.0), 0.05)
    # the detection named b lies nearer to a, but a's own detection is there too: names win over distance
    match = match_frame([a, b], [detected("b", "sphere", (0.005, 0.0, 1.0), 0.05),
                                 detected("a", "sphere", (0.012, 0.0, 1.0), 0.05)], Gate())
    assert sorted((i, j) for i, j, _ in match.pairs) == [(0, 1), (1, 0)]
    twice = match_frame([a], [detected("a", "sphere", a.centre, 0.05), detected("a", "sphere", a.centre, 0.05)],
                        Gate())
    assert len(twice.pairs) == 1 and len(twice.lone_detections) == 1


def test_shape_type_confusion_is_counted() -> None:
    scorer = ShapeScorer(min_visible=0)
    # frame 0: the can reported as a sphere named "ball" (a confusion), the ball right
    scorer.add(FrameTruth(0, None, (CAN, BALL)),
               array(detected("ball", "sphere", CAN.centre, 0.04), detected("ball", "sphere", BALL.centre, 0.06)))
    # frame 1: the can right, the ball missed, a plane where nothing is
    plane = DetectedObject3D("table", OrientedBox(Pose(Point(0.0, 0.5, 2.0))), "plane")
    scorer.add(FrameTruth(1, None, (CAN, BALL)), array(detected("can", "cylinder", CAN.centre, 0.04, CAN.axis), plane))
    result = scorer.result()
    counts = result.to_dict()["confusion"]
    assert counts["rows"] == ["sphere", "cylinder", "box", "nothing"]
    assert counts["columns"] == ["sphere", "cylinder", "box", "other", "missed"]
    assert counts["counts"] == [[1, 0, 0, 0, 1],
                                [1, 1, 0, 0, 0],
                                [0, 0, 0, 0, 0],
                                [0, 0, 0, 1, 0]]
    can, ball, table = result.names["can"], result.names["ball"], result.names["table"]
    assert (can.tp, can.fp, can.fn) == (1, 0, 1)
    assert (ball.tp, ball.fp, ball.fn) == (1, 1, 1)
    assert (table.tp, table.fp, table.fn, table.truth) == (0, 1, 0, 0)
    assert (result.all.tp, result.all.fp, result.all.fn) == (2, 2, 2)
    assert result.score == pytest.approx(0.5)
    assert result.all.precision == pytest.approx(0.5) and result.all.recall == pytest.approx(0.5)


def sphere_points(centre, radius: float, n: int, rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = -np.abs(v[:, 2])  # the side facing the sensor
    return np.asarray(centre) + radius * v


def test_hidden_shapes_are_no_misses() -> None:
    rng = np.random.default_rng(1)
    seen = TruthShape("seen", "sphere", (0.0, 0.0, 1.0), 0.05)
    hidden = TruthShape("hidden", "sphere", (0.5, 0.0, 1.0), 0.05)  # only 20 points show it
    points = np.vstack([sphere_points(seen.centre, 0.05, 400, rng), sphere_points(hidden.centre, 0.05, 20, rng),
                        rng.uniform([-1, -1, 2], [1, 1, 3], (500, 3))]).astype(np.float32)
    frame = type("F", (), {"data": PointCloud(points)})()
    truth = FrameTruth(0, None, (seen, hidden))
    found = array(detected("seen", "sphere", seen.centre, 0.05))
    default = ShapeScorer()
    default.add(truth, found, frame)
    result = default.result()
    assert result.names["hidden"].hidden == 1 and result.names["hidden"].fn == 0 and result.names["hidden"].truth == 0
    assert result.score == 1.0
    strict = ShapeScorer(min_visible=0)
    strict.add(truth, found, frame)
    assert strict.result().names["hidden"].fn == 1 and strict.result().all.recall == 0.5
    # found although hidden: neither right nor wrong
    both = ShapeScorer()
    both.add(truth, array(*found.objects, detected("hidden", "sphere", hidden.centre, 0.05)), frame)
    assert (both.result().all.tp, both.result().all.fp, both.result().all.fn) == (1, 0, 0)
    # no cloud (saved detections): the label file's visible_points decides
    saved = ShapeScorer()
    counted = TruthShape("hidden", "sphere", hidden.centre, 0.05, visible_points=10)
    saved.add(FrameTruth(0, None, (seen, counted)), found, None)
    assert saved.result().names["hidden"].hidden == 1


def test_visible_points_counts_the_points_on_each_solid() -> None:
    rng = np.random.default_rng(2)
    cyl = TruthShape("c", "cylinder", (0.0, 0.0, 1.0), 0.05, (0.0, 1.0, 0.0), 0.2)
    t = rng.uniform(0, 2 * math.pi, 300)
    side = np.stack([0.05 * np.cos(t), rng.uniform(-0.1, 0.1, 300), 1.0 + 0.05 * np.sin(t)], axis=1)
    beyond = np.stack([0.05 * np.cos(t[:50]), np.full(50, 0.13), 1.0 + 0.05 * np.sin(t[:50])], axis=1)  # 3 cm past
    assert visible_points(np.vstack([side, beyond]), cyl, 0.01) == 300
    rot = rotation_with_y((1.0, 1.0, 0.0))
    box = TruthShape("b", "box", (0.0, 0.0, 2.0), size=(0.2, 0.4, 0.1),
                     orientation=tuple(vars(Quaternion.from_matrix(rot)).values()))
    local = rng.uniform(-0.5, 0.5, (1000, 3)) * np.array([0.2, 0.4, 0.1])
    outside = rng.uniform(-0.5, 0.5, (100, 3)) * np.array([0.2, 0.4, 0.1]) + np.array([0.0, 0.0, 0.2])  # 10+ cm above
    points = np.vstack([local, outside]) @ rot.T + np.array([0.0, 0.0, 2.0])
    assert visible_points(points, box, 0.005) == 1000


def test_visible_counts_in_a_whole_cloud_equal_the_exact_count() -> None:
    """The column pre-test over a cloud with missing returns (NaN) keeps every point the exact test counts."""
    from objrec3d.demo import demo_scene

    cloud, demo = demo_scene(3, 0)
    shapes = get_kind("3d").frame_truth(type("F", (), {"truth": demo, "index": 0, "stamp_ns": None})()).objects
    valid = cloud.points[cloud.valid_mask()].astype(np.float64)
    exact = [visible_points(valid, s, 0.01) for s in shapes]
    assert visible_counts(cloud.points, shapes, 0.01) == exact
    assert min(exact) > 500  # the demo's cylinder and sphere are in full view


def test_identity_switches_and_idf1_on_a_constructed_sequence() -> None:
    """Two objects A and B standing still over six frames; the tracker's ids: frames 0-1 A=1 B=2, frames 2-3
    swapped (A=2, B=1: two switches), frame 4 A gets a new id 3 (a third switch) and B is missed, frame 5
    A=3 B=1 (B back on its last id: no switch).

    IDF1 by hand: frames each truth/id pair correspond: (A,1)=2, (A,2)=2, (A,3)=2, (B,2)=2, (B,1)=3; the best
    one-to-one assignment is A-2 with B-1 (or A-3 with B-1): IDTP = 5. Truth sightings 12, detections 11:
    IDFN = 7, IDFP = 6, IDF1 = 2*5 / (2*5 + 6 + 7) = 10/23."""
    a = TruthShape("A", "sphere", (0.0, 0.0, 1.0), 0.05)
    b = TruthShape("B", "sphere", (0.5, 0.0, 1.0), 0.05)
    ids = [("1", "2"), ("1", "2"), ("2", "1"), ("2", "1"), ("3", None), ("3", "1")]
    scorer = ShapeScorer(min_visible=0)
    for index, (ia, ib) in enumerate(ids):
        objects = [detected("A", "sphere", (0.002, 0.0, 1.0), 0.05, ident=ia)]
        if ib is not None:
            objects.append(detected("B", "sphere", (0.5, 0.003, 1.0), 0.05, ident=ib))
        scorer.add(FrameTruth(index, None, (a, b)), array(*objects))
    tracking = scorer.result().tracking
    assert tracking is not None
    assert tracking.id_switches == 3
    assert (tracking.idtp, tracking.idfp, tracking.idfn) == (5, 6, 7)
    assert tracking.idf1 == pytest.approx(10 / 23)
    assert tracking.idp == pytest.approx(5 / 11) and tracking.idr == pytest.approx(5 / 12)
    assert (tracking.truth_tracks, tracking.tracks) == (2, 3)
    row = scorer.result().summary_rows()[-1]
    assert row["name"] == "all" and row["idf1"] == pytest.approx(10 / 23) and row["id_switches"] == 3


def test_idf1_against_scipy_on_random_sequences() -> None:
    """The global assignment equals SciPy's linear_sum_assignment on the same co-occurrence table."""
    from scipy.optimize import linear_sum_assignment

    rng = np.random.default_rng(5)
    score_ = TrackingScore()
    table: dict[tuple[str, str], int] = {}
    truths = [(f"t{i}", (float(i), 0.0, 1.0), 0.05) for i in range(5)]
    n_truth = n_det = 0
    for _ in range(40):
        dets = []
        for name, centre, _gate in truths:
            if rng.random() < 0.85:
                ident = f"h{rng.integers(0, 7)}"
                if any(d[0] == ident for d in dets):
                    continue
                dets.append((ident, centre))
                table[(name, ident)] = table.get((name, ident), 0) + 1
        score_.add(truths, dets)
        n_truth += len(truths)
        n_det += len(dets)
    names = sorted({k[0] for k in table})
    hyps = sorted({k[1] for k in table})
    m = np.array([[table.get((t, h), 0) for h in hyps] for t in names])
    rows, cols = linear_sum_assignment(-m)
    idtp = int(m[rows, cols].sum())
    figures = score_.figures()
    assert figures.idtp == idtp
    assert figures.idf1 == pytest.approx(2 * idtp / (n_truth + n_det))


def test_no_ids_no_tracking_figures_and_the_bars() -> None:
    scorer = ShapeScorer(min_visible=0)
    scorer.add(FrameTruth(0, None, (CAN, BALL)), array(detected("ball", "sphere", (0.2, 0.2, 1.23), 0.06)))
    result = scorer.result()
    assert result.tracking is None and "idf1" not in result.summary_rows()[-1]
    assert result.score == pytest.approx(2 / 3)
    assert result.below({"f1": 0.5, "centre_error_p90": 0.05}) == []
    assert result.below({"f1": 0.9, "recall": 0.6, "centre_error_p90": 0.01}) == [
        "f1 0.6667 < 0.9", "recall 0.5 < 0.6", "centre_error_p90 0.03 > 0.01"]
    assert result.below({"axis_error_p90": 5.0}) == ["axis_error_p90 not measured (no true positive) > 5"]
    assert result.below({"idf1": 0.5}) == ["idf1 not measured (no tracking ids) < 0.5"]
    with pytest.raises(KeyError, match=r"'ap' is no 3D bar \(known: f1"):
        result.below({"ap": 0.5})


def test_nothing_to_find_and_nothing_found_is_perfect() -> None:
    scorer = ShapeScorer()
    scorer.add(FrameTruth(0, None, ()), array())
    assert scorer.result().score == 1.0
    scorer.add(FrameTruth(1, None, ()), array(detected("ball", "sphere", (0, 0, 1), 0.05)))
    assert scorer.result().score == 0.0 and scorer.result().all.precision == 0.0


def test_bad_options_are_refused() -> None:
    with pytest.raises(ValueError, match="match_distance"):
        ShapeScorer(match_distance=0)
    with pytest.raises(ValueError, match="min_visible"):
        ShapeScorer(min_visible=-1)
    with pytest.raises(TypeError, match="iou"):
        get_kind("3d").scorer(iou=0.5)


def test_shape_demo_scored_on_its_own_truth(tmp_path) -> None:
    """params/shape_demo.yaml on 8 frames of two demo scenes: F1 = 1.0 (16 of 16 shapes found, nothing else),
    centre errors under 2 cm (p90 about 1 cm: the cylinder's centre from its visible side), radius errors
    under 2 mm, cylinder axes within 2 degrees; the tracker keeps each object's id (IDF1 1, no switch)."""
    kind = get_kind("3d")
    for spec in ("demo:seed=0,frames=4", "demo:seed=3,frames=4"):
        frames = [(f, kind.frame_truth(f)) for f in open_source(spec, "3d")]
        result = score(build_system("params/shape_demo.yaml"), kind, frames)
        assert isinstance(result, ShapeEvaluation)
        row = result.summary_rows()[-1]
        assert (row["tp"], row["fp"], row["fn"], row["hidden"]) == (8, 0, 0, 0)
        assert result.score == 1.0
        assert row["centre_error_p90"] < 0.02 and row["radius_error_p90"] < 0.002 and row["axis_error_p90"] < 2.0
        assert result.tracking is not None and result.tracking.idf1 == 1.0 and result.tracking.id_switches == 0
    # the same detections saved and scored against the truth file give the same figures
    truth_path = tmp_path / "truth.yaml"
    with open_source(f"demo:seed=3,frames=4,truth={truth_path}", "3d") as source:
        frames = [(f, kind.frame_truth(f)) for f in source]
    system = build_system("params/shape_demo.yaml")
    live = score(system, kind, frames, min_visible=0)
    from objrec_core import DetectionDirector

    director = DetectionDirector(build_system("params/shape_demo.yaml"))
    saved = [director.process(f) for f, _ in frames]
    offline = score_saved(kind, saved, kind.read_truth(truth_path), min_visible=0)
    assert offline.to_dict()["all"] == live.to_dict()["all"]


def test_report_and_pictures(tmp_path) -> None:
    kind = get_kind("3d")
    scorer = kind.scorer()
    system_frames = list(open_source("demo:seed=2,frames=2", "3d"))
    for frame in system_frames:
        truth = kind.frame_truth(frame)
        # the cylinder missed and a stray sphere reported: every frame has errors to show
        scorer.add(truth, array(detected("sphere", "sphere", truth.objects[1].centre, 0.06),
                                detected("sphere", "sphere", (0.0, 0.0, 1.5), 0.05)), frame)
    result = scorer.result()
    assert [w.truth.index for w in result.worst] == [0, 1]
    report = result.markdown()
    assert "| name | truth |" in report and "| cylinder | 2 | 0 | 0 | 0 | 2 |" in report
    written = result.pictures(tmp_path)
    assert [p.name for p in written] == ["3d-errors.png", "3d-confusion.png", "3d-worst-1.png", "3d-worst-2.png"]
    errors = cv2.imread(str(tmp_path / "3d-errors.png"))
    assert errors.shape == (300, 1260, 3)
    worst = cv2.imread(str(tmp_path / "3d-worst-1.png"))
    assert worst.shape == (480, 640, 3)
    # the truth box is drawn in green, the detections in red
    green = (worst[..., 1] > 200) & (worst[..., 0] < 100) & (worst[..., 2] < 100)
    red = (worst[..., 2] > 200) & (worst[..., 0] < 100) & (worst[..., 1] < 100)
    assert green.sum() > 100 and red.sum() > 100
    data = result.to_dict()
    assert data["score"] == result.score and data["tracking"] is None
    assert data["worst_frames"][0] == {"index": 0, "stamp_ns": None, "misses_and_false": 2}


def test_truth_set_lookup_and_scoring_by_stamp() -> None:
    shapes = (BALL,)
    truth = TruthSet("3d", [FrameTruth(None, 5_000, shapes)], keyed_by="stamp")
    from objrec_core import Header

    hit = DetectedObject3DArray(Header(stamp=5e-6, stamp_ns=5_000), [detected("ball", "sphere", BALL.centre, 0.06)])
    miss = DetectedObject3DArray(Header(stamp=6e-6, stamp_ns=6_000), [])
    result = score_saved(get_kind("3d"), [miss, hit], truth)
    assert result.frames == 1 and result.score == 1.0
