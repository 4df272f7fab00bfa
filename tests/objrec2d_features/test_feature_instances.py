"""Several copies of one target in a frame, the homography estimator's iterations and confidence, ORB on the
classic box pair with inlier coverage to spare, and every reason the detector gives for finding nothing."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from objrec2d import DetectionStatus, FeatureDetector
from objrec2d.demo import render_pattern
from objrec2d.features import corner_error, rect_corners
from objrec2d.features.geometry import inside_convex, overlap
from objrec_core import Rect, build_system

DEFAULTS = FeatureDetector.default_values()

WIDTH, HEIGHT = 200, 150  # the poster
POSTER = cv2.cvtColor(render_pattern(WIDTH, HEIGHT, seed=7), cv2.COLOR_GRAY2BGR)
OUTLINE = rect_corners(Rect(0, 0, WIDTH, HEIGHT)).astype(np.float64)


def pose(cx: float, cy: float, scale: float, angle: float, tilt: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """A homography that centres the poster on (cx, cy), scaled, turned and tilted."""
    a = np.deg2rad(angle)
    c, s = np.cos(a) * scale, np.sin(a) * scale
    centre = np.array([[1, 0, -WIDTH / 2], [0, 1, -HEIGHT / 2], [0, 0, 1.0]])
    perspective = np.array([[1, 0, 0], [0, 1, 0], [tilt[0], tilt[1], 1.0]])
    return np.array([[c, -s, cx], [s, c, cy], [0, 0, 1.0]]) @ perspective @ centre


def paste(scene: np.ndarray, poses: list[np.ndarray]) -> list[np.ndarray]:
    """Warp the poster into ``scene`` at each pose (later ones on top); the true outlines."""
    height, width = scene.shape[:2]
    truths = []
    for matrix in poses:
        warped = cv2.warpPerspective(POSTER, matrix, (width, height), flags=cv2.INTER_LINEAR)
        mask = cv2.warpPerspective(np.full((HEIGHT, WIDTH), 255, np.uint8), matrix, (width, height),
                                   flags=cv2.INTER_NEAREST)
        scene[mask > 0] = warped[mask > 0]
        truths.append(cv2.perspectiveTransform(OUTLINE.reshape(-1, 1, 2), matrix).reshape(-1, 2))
    return truths


def background(width: int = 800, height: int = 600) -> np.ndarray:
    """A textured background of another pattern, paler, so it holds keypoints that must not match."""
    other = cv2.resize(render_pattern(200, 150, seed=99), (width, height))
    return cv2.cvtColor((other * 0.6 + 60).astype(np.uint8), cv2.COLOR_GRAY2BGR)


THREE_POSES = [
    pose(180, 150, 0.9, 10, (4e-4, 0.0)),
    pose(560, 170, 0.7, -25, (0.0, 5e-4)),
    pose(400, 440, 0.8, 160, (-3e-4, 2e-4)),
]


@pytest.fixture(scope="module")
def three_copies() -> tuple[np.ndarray, list[np.ndarray]]:
    scene = background()
    return scene, paste(scene, THREE_POSES)


def assign(objects: list, truths: list[np.ndarray]) -> list[tuple[int, float]]:
    """For each found outline, the nearest true copy and its corner error."""
    found = []
    for obj in objects:
        errors = [corner_error(np.array(obj.polygon.xy()), truth) for truth in truths]
        found.append((int(np.argmin(errors)), min(errors)))
    return found


# -- several copies ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("feature_type", ["ORB", "SIFT"])
def test_three_pasted_copies_are_all_found_within_3_px(three_copies, feature_type):
    scene, truths = three_copies
    detector = FeatureDetector(feature_type=feature_type, max_instances=3, object_name="poster")
    detector.set_target(POSTER)
    objects = detector.detect(scene)
    matched = assign(objects, truths)
    assert sorted(index for index, _ in matched) == [0, 1, 2], matched  # each copy once: no duplicates
    assert max(error for _, error in matched) < 3.0, matched
    assert [o.name for o in objects] == ["poster"] * 3
    result = objects.details[0]
    assert result.found and objects.reason is None and len(result.instances) == 3
    counts = [instance.inlier_count for instance in result.instances]
    assert counts == sorted(counts, reverse=True) and min(counts) >= 40  # best supported first
    assert result.inlier_count == counts[0]  # the record's own fields describe the first copy
    assert result.next_reason is None  # max_instances was reached
    # No outline shares area with another.
    outlines = [np.array(o.polygon.xy()) for o in objects]
    assert max(overlap(a, b) for i, a in enumerate(outlines) for b in outlines[i + 1:]) == 0.0


def test_max_instances_caps_the_copies_and_says_why_it_stopped(three_copies):
    scene, truths = three_copies
    detector = FeatureDetector(max_instances=2)
    detector.set_target(POSTER)
    two = assign(detector.detect(scene), truths)
    assert len(two) == 2 and len({index for index, _ in two}) == 2 and max(e for _, e in two) < 3.0
    single = FeatureDetector()  # the default: one copy
    single.set_target(POSTER)
    assert FeatureDetector.default_values()["max_instances"] == 1
    one = assign(single.detect(scene), truths)
    assert len(one) == 1 and one[0][1] < 3.0
    more = FeatureDetector(max_instances=5)
    more.set_target(POSTER)
    three = more.detect(scene)
    assert len(three) == 3
    assert three.details[0].next_reason.startswith("too few matches: ")  # why no 4th copy
    assert three.reason is None  # something was found


def test_a_copy_found_again_is_not_reported_twice():
    """Two copies, one covering 40 % of the other (their outlines' overlap, intersection over union, is
    0.25): both are reported at the default limit of 0.5; with a limit below their overlap the second
    counts as the first found again and is dropped."""
    scene = background(640, 480)
    truths = paste(scene, [pose(250, 220, 1.0, 0), pose(350, 250, 1.0, 0)])
    assert 0.2 < overlap(*truths) < 0.3
    detector = FeatureDetector(max_instances=3)
    detector.set_target(POSTER)
    both = assign(detector.detect(scene), truths)
    assert sorted(index for index, _ in both) == [0, 1]
    assert max(error for _, error in both) < 3.0
    strict = FeatureDetector(max_instances=3, max_instance_overlap=0.15)
    strict.set_target(POSTER)
    assert len(strict.detect(scene)) == 1


def test_inside_convex_takes_either_winding():
    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    points = np.array([[5, 5], [0, 0], [10, 5], [11, 5], [-0.1, 3]], float)
    assert inside_convex(points, square).tolist() == [True, True, True, False, False]
    assert inside_convex(points, square[::-1]).tolist() == [True, True, True, False, False]
    assert inside_convex(np.empty((0, 2)), square).shape == (0,)


# -- the estimator's iterations and confidence ---------------------------------------------------------------
def low_inlier_scene() -> tuple[np.ndarray, np.ndarray]:
    """The poster among 20 pieces of other posters: with a loose ratio (0.95) about 12 % of the matches
    are right (34 of 275 with OpenCV 5.0)."""
    rng = np.random.default_rng(3)
    scene = np.full((480, 640, 3), 128, np.uint8)
    for _ in range(20):
        piece = cv2.cvtColor(render_pattern(120, 90, seed=int(rng.integers(1000, 2000))), cv2.COLOR_GRAY2BGR)
        x, y = int(rng.integers(0, 640 - 120)), int(rng.integers(0, 480 - 90))
        scene[y : y + 90, x : x + 120] = piece
    matrix = np.array([[1.0, 0, 250], [0, 1.0, 180], [0, 0, 1.0]])
    return scene, paste(scene, [matrix])[0]


def test_too_few_iterations_miss_a_model_the_defaults_find():
    scene, truth = low_inlier_scene()
    found = FeatureDetector(ratio=0.95)
    found.set_target(POSTER)
    objects = found.detect(scene)
    result = objects.details[0]
    assert len(objects) == 1, objects.reason
    assert corner_error(np.array(objects[0].polygon.xy()), truth) < 3.0
    assert result.inlier_count / len(result.matches) < 0.2  # a scene with few inliers indeed
    few = FeatureDetector(ratio=0.95, homography_max_iterations=50)
    few.set_target(POSTER)
    missed = few.detect(scene)
    assert missed == []
    assert missed.details[0].status in {DetectionStatus.TOO_FEW_INLIERS, DetectionStatus.NO_HOMOGRAPHY}, missed.reason


def test_the_estimator_gets_the_iterations_and_confidence(monkeypatch, three_copies):
    scene, _ = three_copies
    calls = []
    real = cv2.findHomography

    def spy(*args, **kwargs):
        if args[2] != 0:  # the robust estimator; method 0 is the least-squares refit on its inliers
            calls.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(cv2, "findHomography", spy)
    detector = FeatureDetector(homography_max_iterations=1234, homography_confidence=0.9)
    detector.set_target(POSTER)
    detector.detect(scene)
    assert calls and all(c["maxIters"] == 1234 and c["confidence"] == 0.9 for c in calls)
    defaults = FeatureDetector.default_values()
    assert (defaults["homography_max_iterations"], defaults["homography_confidence"]) == (20000, 0.999)


# -- ORB on the classic pair ---------------------------------------------------------------------------------
def jittered(scene: np.ndarray, count: int) -> list[np.ndarray]:
    """A hand-held camera's view of the same scene: turned up to 4°, scaled 0.92-1.08, shifted up to
    8 px, brighter or darker by up to 20 %, with sensor noise."""
    rng = np.random.default_rng(1)
    views = []
    for _ in range(count):
        matrix = cv2.getRotationMatrix2D((256, 192), rng.uniform(-4, 4), rng.uniform(0.92, 1.08))
        matrix[:, 2] += rng.uniform(-8, 8, 2)
        view = cv2.warpAffine(scene, matrix, scene.shape[1::-1], borderMode=cv2.BORDER_REFLECT)
        view = view.astype(np.float32) * rng.uniform(0.8, 1.2) + rng.normal(0, 3, view.shape)
        views.append(np.clip(view, 0, 255).astype(np.uint8))
    return views


@pytest.mark.realdata
def test_orb_defaults_cover_the_box_with_room_to_spare(box, box_in_scene):
    """Without context around the target ORB's inliers span 12 % of box.png, just above the 10 % refusal
    limit (11 % at worst on these shaken views). With it they span 24 % on the still pair, every time, and
    on the 16 shaken views 17 % at worst (0.13 asserted) and 24 % in the median."""
    detector = FeatureDetector(object_name="box")
    detector.set_target(box)
    coverages = []
    for _ in range(5):
        still = detector.detect(box_in_scene)
        assert len(still) == 1, still.reason
        coverages.append(still.details[0].coverage)
    assert len(set(coverages)) == 1 and coverages[0] >= 0.2, coverages
    assert still.details[0].inlier_count >= 40
    shaken = []
    for view in jittered(box_in_scene, 16):
        moved = detector.detect(view)
        assert len(moved) == 1, moved.reason
        shaken.append(moved.details[0].coverage)
    assert min(shaken) >= 0.13 and np.median(shaken) >= 0.2, shaken


# -- reasons --------------------------------------------------------------------------------------------------
def detector_on_poster(**parameters) -> FeatureDetector:
    detector = FeatureDetector(**parameters)
    detector.set_target(POSTER)
    return detector


def test_every_reason_for_finding_nothing(three_copies, monkeypatch):
    scene, _ = three_copies
    # No target.
    empty = FeatureDetector()
    assert empty.ready() == "no target: select one in objrec-define (drag a rectangle around the object)"
    result = empty.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.NO_TARGET
    assert result.reason == empty.ready()
    # A target that has no keypoints with the current settings.
    faint = (POSTER.astype(np.float32) * 0.2 + 128 * 0.8).astype(np.uint8)
    plain = FeatureDetector()
    plain.set_target(faint)
    assert plain.ready() is None
    plain.set_parameters(orb_fast_threshold=60)
    assert plain.ready() == (
        "the target has no ORB keypoints with these settings, 10 are needed (min_matches/min_inliers): "
        "select a textured area"
    )
    result = plain.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.NO_TARGET
    assert result.reason == "the target has no ORB keypoints with these settings; select a textured area"
    # Fewer target keypoints than a detection needs.
    demanding = detector_on_poster()
    count = len(demanding.target)
    demanding.set_parameters(min_matches=count + 1)
    assert demanding.ready() == (
        f"the target has only {count} ORB keypoints with these settings, {count + 1} are needed "
        "(min_matches/min_inliers): select a textured area"
    )
    # A plain frame.
    blank = np.full((480, 640, 3), 90, np.uint8)
    detector = detector_on_poster()
    assert detector.ready() is None
    result = detector.detect(blank)
    assert result == [] and result.details[0].status is DetectionStatus.TOO_FEW_KEYPOINTS
    assert result.reason == (
        "too few keypoints in the frame: 0 ORB keypoints, min_matches is 10 (a plain, dark or blurred frame?)"
    )
    # Too few matches.
    choosy = detector_on_poster(min_matches=500)
    result = choosy.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.TOO_FEW_MATCHES
    matches, keypoints = len(result.details[0].matches), len(result.details[0].frame_points)
    assert 0 < matches < 500 and keypoints == 1000
    assert result.reason == f"too few matches: {matches} of 1000 keypoints, min_matches is 500"
    # Too few inliers.
    found = detector_on_poster()
    attempt = found.detect(scene)
    assert attempt
    inliers, matches = attempt.details[0].inlier_count, len(attempt.details[0].matches)
    strict = detector_on_poster(min_inliers=inliers + 1)
    result = strict.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.TOO_FEW_INLIERS
    assert result.reason == f"too few inliers: {inliers} of {matches} matches, min_inliers is {inliers + 1}"
    # Inliers bunched.
    bunched = detector_on_poster(min_inlier_coverage=0.95)
    result = bunched.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.BUNCHED_INLIERS
    coverage = result.details[0].coverage
    assert result.reason == f"inliers bunched: they span {coverage:.0%} of the target, min_inlier_coverage is 95%"
    # Degenerate outlines: too small, too large, squashed.
    small = detector_on_poster(min_area=1e6)
    result = small.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.DEGENERATE_POLYGON
    assert result.reason.startswith("degenerate polygon: area ")
    assert result.reason.endswith("is below min_area 1000000 px²")
    large = detector_on_poster(max_area_fraction=0.01).detect(scene)
    assert large == []
    assert large.reason.startswith("degenerate polygon: area ")
    assert large.reason.endswith("is more than 0.01 times the frame's")
    squashed = detector_on_poster(min_corner_angle=89.0).detect(scene)
    assert squashed == []
    assert squashed.reason.startswith("degenerate polygon: a corner angle of ")
    assert squashed.reason.endswith("lies outside 89°..91° (squashed)")
    # No homography at all.
    monkeypatch.setattr(cv2, "findHomography", lambda *args, **kwargs: (None, None))
    hopeless = detector_on_poster()
    result = hopeless.detect(scene)
    assert result == [] and result.details[0].status is DetectionStatus.NO_HOMOGRAPHY
    matches = len(result.details[0].matches)
    assert result.reason == (
        f"no homography fits the {matches} matches (USAC_MAGSAC, homography_max_iterations is 20000)"
    )



# -- parameter files ---------------------------------------------------------------------------------------
NEW_KEYS = ("homography_max_iterations", "homography_confidence", "max_instances", "max_instance_overlap")


def test_a_file_without_the_new_keys_loads_with_their_defaults(project_root, tmp_path):
    """Files written before these parameters existed leave them out; they load with the defaults, and the
    shipped demo file spells them out."""
    text = (project_root / "params" / "feature_demo.yaml").read_text()
    document = yaml.safe_load(text)
    parameters = document["pipeline"][0]["parameters"]
    assert {key: parameters[key] for key in NEW_KEYS} == {key: DEFAULTS[key] for key in NEW_KEYS}
    for key in NEW_KEYS:
        del parameters[key]
    old = tmp_path / "old.yaml"
    old.write_text(yaml.safe_dump(document))
    detector = build_system(old).detectors[0]
    assert {key: getattr(detector.params, key) for key in NEW_KEYS} == {key: DEFAULTS[key] for key in NEW_KEYS}
    assert detector.ready() is None and len(detector.target) > 500
