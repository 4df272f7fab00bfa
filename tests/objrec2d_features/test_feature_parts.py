"""The parts on their own: factory look-up in OpenCV 4 and 5 places, which parameters matter for which
feature type, the norm and index chosen from the descriptor, the ratio test and cross check, the homography's
sanity checks, and the failure reasons."""

from __future__ import annotations

import threading
import time
import types

import cv2
import numpy as np
import pytest

from objrec2d import DemoScene, DetectionStatus, FeatureDetector
from objrec2d.features import (
    FEATURE_TYPES,
    FeatureConfig,
    FeatureUnavailable,
    PolygonLimits,
    TrainedMatcher,
    available_feature_types,
    check_quadrilateral,
    corner_error,
    create_feature2d,
    rect_corners,
)
from objrec2d.features import geometry as geometry_module
from objrec2d.features import types as types_module
from objrec_core import ParameterError, Rect, SelectionRefused

DEFAULTS = FeatureDetector.default_values()


def snapshot(**changes: object) -> object:
    """A parameter snapshot like ``detector.params``: the defaults with some values changed."""
    return FeatureDetector.Parameters(**(DEFAULTS | changes))


@pytest.fixture
def fake_cv2(monkeypatch):
    """A cv2 stand-in whose AKAZE lives only in xfeatures2d, as in OpenCV 5 contrib, and no SURF."""
    made = []

    def akaze_create(**kwargs):
        made.append(kwargs)
        return "an AKAZE"

    fake = types.SimpleNamespace(
        __version__="5.0.0-fake",
        error=cv2.error,
        ORB_create=cv2.ORB_create,
        xfeatures2d=types.SimpleNamespace(AKAZE_create=akaze_create),
    )
    monkeypatch.setattr(types_module, "cv2", fake)
    types_module.unavailable_reason.cache_clear()
    yield made
    types_module.unavailable_reason.cache_clear()


def test_factories_are_found_in_cv2_or_in_xfeatures2d(fake_cv2):
    assert types_module.unavailable_reason("ORB") is None
    assert types_module.unavailable_reason("AKAZE") is None
    config = FeatureConfig.from_parameters(snapshot(feature_type="AKAZE"))
    assert create_feature2d(config) == "an AKAZE"
    assert fake_cv2[-1] == {"threshold": 0.001}
    reason = types_module.unavailable_reason("BRISK")
    assert "BRISK is not available in the installed OpenCV 5.0.0-fake" in reason and "contrib" in reason
    assert "non-free" in types_module.unavailable_reason("SURF")


def test_surf_that_refuses_to_be_created_is_unavailable(monkeypatch):
    def surf_create(**kwargs):
        raise cv2.error("OpenCV(5.0.0) surf.cpp:1026: error: (-213:...) This algorithm is patented")

    contrib = types.SimpleNamespace(SURF_create=surf_create)
    fake = types.SimpleNamespace(__version__="5.0.0-fake", error=cv2.error, xfeatures2d=contrib)
    monkeypatch.setattr(types_module, "cv2", fake)
    types_module.unavailable_reason.cache_clear()
    try:
        reason = types_module.unavailable_reason("SURF")
        assert reason.startswith("SURF cannot be created in the installed OpenCV 5.0.0-fake")
        assert "patented" in reason and "surf.cpp" not in reason
        with pytest.raises(FeatureUnavailable, match="SURF cannot be created"):
            types_module.check_available("SURF")
    finally:
        types_module.unavailable_reason.cache_clear()


def test_the_real_opencv_has_orb_and_sift_and_says_why_for_the_rest():
    available = available_feature_types()
    assert {"ORB", "SIFT"} <= set(available)
    for name in set(FEATURE_TYPES) - set(available):
        assert cv2.__version__ in types_module.unavailable_reason(name)
        with pytest.raises(ParameterError, match=f"feature_type='{name}' is invalid: not available here: {name} "):
            FeatureDetector().set_parameters(feature_type=name)


def test_the_feature_type_choice_offers_only_what_this_opencv_can_make():
    spec = FeatureDetector.parameter_spec("feature_type")
    available = available_feature_types()
    assert spec.available_choices == tuple(available)
    missing = [t for t in FEATURE_TYPES if t not in available]
    assert spec.unavailable == {t: types_module.unavailable_reason(t) for t in missing}
    assert spec.describe() == "one of " + ", ".join(available)  # what error messages and tooltips offer
    assert spec.default in spec.available_choices  # a new detector must be possible everywhere


@pytest.mark.skipif(types_module.unavailable_reason("SURF") is None, reason="this OpenCV has non-free SURF")
def test_surf_is_refused_with_its_reason_where_it_is_unavailable():
    reason = types_module.unavailable_reason("SURF")
    assert reason.startswith("SURF ") and cv2.__version__ in reason
    detector = FeatureDetector(feature_type="SIFT")
    with pytest.raises(ParameterError) as caught:
        detector.set_parameters(feature_type="SURF", surf_hessian_threshold=800.0)
    assert caught.value.parameter == "feature_type" and caught.value.value == "SURF"
    assert caught.value.rule == f"not available here: {reason}"
    assert str(caught.value) == (
        f"FeatureDetector: parameter feature_type='SURF' is invalid: not available here: {reason}"
    )
    assert detector.feature_type == "SIFT" and detector.surf_hessian_threshold == 400.0  # nothing was applied
    with pytest.raises(ParameterError, match="not available here: SURF "):
        FeatureDetector(feature_type="SURF")


def test_each_types_own_settings_are_relevant_only_for_that_type():
    detector = FeatureDetector()
    shared = ["view_tilts", "matcher", "ratio_test", "ratio", "cross_check", "min_matches", "homography_method",
              "reprojection_threshold", "homography_max_iterations", "homography_confidence", "photometric_refinement",
              "min_inliers",
              "min_inlier_coverage", "min_area", "max_area_fraction", "min_corner_angle", "max_instances",
              "debug_view"]
    orb = ["feature_type", "max_features", "orb_scale_factor", "orb_levels", "orb_fast_threshold"]
    assert detector.relevant_parameters() == orb + shared
    detector.set_parameters(feature_type="SIFT")
    assert detector.relevant_parameters() == ["feature_type", "max_features", "sift_contrast_threshold", *shared]
    # Other values can be asked about without setting them; AKAZE keeps no max_features.
    akaze = detector.relevant_parameters(detector.get_parameters() | {"feature_type": "AKAZE"})
    assert akaze == ["feature_type", "akaze_threshold", *shared]
    surf = detector.relevant_parameters(detector.get_parameters() | {"feature_type": "SURF"})
    assert surf == ["feature_type", "surf_hessian_threshold", *shared]
    # The ratio only matters with the ratio test; LMEDS has no reprojection threshold.
    others = detector.relevant_parameters(
        detector.get_parameters() | {"ratio_test": False, "homography_method": "LMEDS"}
    )
    assert "ratio" not in others and "reprojection_threshold" not in others and "ratio_test" in others
    assert "homography_max_iterations" not in others and "homography_confidence" in others  # LMEDS sets its own
    several = detector.relevant_parameters(detector.get_parameters() | {"max_instances": 3})
    assert several[-3:] == ["max_instances", "max_instance_overlap", "debug_view"]
    spec = FeatureDetector.parameter_spec("orb_levels")
    assert spec.relevance_text() == "only when feature_type is ORB"
    # Every type-specific setting is relevant exactly for the types whose configuration includes it.
    for name in types_module.FEATURE_PARAMETERS - {"feature_type"}:
        users = {t for t, settings in types_module.TYPE_SETTINGS.items() if name in settings}
        relevant = {t for t in FEATURE_TYPES if FeatureDetector.parameter_spec(name).is_relevant(
            DEFAULTS | {"feature_type": t})}
        assert relevant == users, name
    # An irrelevant value is still kept, and saved: relevance only decides what a panel shows.
    detector.set_parameters(orb_levels=5)
    assert detector.get_parameters()["orb_levels"] == 5


def test_only_the_chosen_types_settings_make_up_its_configuration():
    orb = FeatureConfig.from_parameters(snapshot())
    assert orb.to_dict() == {
        "type": "ORB", "max_features": 1000, "orb_scale_factor": 1.2, "orb_levels": 8, "orb_fast_threshold": 20,
    }
    assert FeatureConfig.from_parameters(snapshot(sift_contrast_threshold=0.1)) == orb
    assert FeatureConfig.from_parameters(snapshot(feature_type="SIFT")).to_dict() == {
        "type": "SIFT", "max_features": 1000, "sift_contrast_threshold": 0.04,
    }


def descriptors_for(feature_type: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Target and frame descriptors of one textured image and a shifted copy."""
    image = DemoScene(seed=0).render(0)[0][150:330, 200:440]
    config = FeatureConfig.from_parameters(snapshot(feature_type=feature_type))
    extractor = create_feature2d(config)
    _, target = extractor.detectAndCompute(image, None)
    _, frame = extractor.detectAndCompute(np.roll(image, (3, 5), axis=(0, 1)), None)
    return target, frame, int(extractor.defaultNorm())


@pytest.mark.parametrize(
    ("feature_type", "norm", "dtype"), [("ORB", cv2.NORM_HAMMING, np.uint8), ("SIFT", cv2.NORM_L2, np.float32)]
)
@pytest.mark.parametrize("kind", ["brute_force", "flann"])
def test_the_norm_and_index_follow_the_descriptor(feature_type, norm, dtype, kind):
    target, frame, default_norm = descriptors_for(feature_type)
    assert default_norm == norm and target.dtype == dtype
    matcher = TrainedMatcher(target, default_norm, kind)
    assert matcher.binary is (feature_type == "ORB")
    plain = matcher.match(frame, ratio=None, cross_check=False)
    strict = matcher.match(frame, ratio=0.7, cross_check=False)
    mutual = matcher.match(frame, ratio=0.7, cross_check=True)
    assert len(plain) >= len(strict) >= len(mutual) > 30
    for found in (plain, strict, mutual):
        assert len(np.unique(found.target_idx)) == len(found)  # one-to-one
    other_target, _, _ = descriptors_for("SIFT" if feature_type == "ORB" else "ORB")
    with pytest.raises(ValueError, match="cannot be compared"):
        matcher.match(other_target, ratio=0.8, cross_check=False)


def test_the_ratio_test_and_cross_check_on_made_up_descriptors():
    target = np.array([[0] * 8, [255] * 8, [0x0F] * 8], dtype=np.uint8)
    frame = np.array([[0] * 7 + [1], [0x0F] * 7 + [0x0E], [0x33] * 8, [1] + [0] * 7], dtype=np.uint8)
    matcher = TrainedMatcher(target, cv2.NORM_HAMMING)
    everything = matcher.match(frame, ratio=None, cross_check=False)
    # Frame 0 and frame 3 both take target 0 at distance 1: one-to-one keeps one of them.
    assert sorted(zip(everything.frame_idx.tolist(), everything.target_idx.tolist(), strict=True))[0][1] == 0
    assert sorted(everything.target_idx.tolist()) == [0, 2]
    # Frame 2 (0x33...) is 32 bits from both target 0 and target 2: ambiguous, the ratio test drops it.
    strict = matcher.match(frame, ratio=0.8, cross_check=False)
    assert 2 not in strict.frame_idx.tolist()
    mutual = matcher.match(frame, ratio=0.8, cross_check=True)
    assert sorted(zip(mutual.frame_idx.tolist(), mutual.target_idx.tolist(), strict=True)) == [(0, 0), (1, 2)]


SQUARE = rect_corners(Rect(10, 10, 100, 100))


@pytest.mark.parametrize(
    ("points", "reason"),
    [
        (SQUARE, None),
        (SQUARE[[0, 2, 1, 3]], "not convex"),  # a bow tie
        (SQUARE[::-1], "mirrored"),
        (np.array([[0, 0], [4, 0], [4, 4], [0, 4]], float), "below min_area"),
        (SQUARE * 20, "times the frame's"),
        (np.array([[0, 0], [200, 0], [240, 8], [40, 8]], float), "squashed"),  # 11° corners
        (np.array([[0, 0], [100, 0], [100, 100], [99.5, 100]], float), "shorter than a pixel"),
    ],
)
def test_the_quadrilateral_checks(points, reason):
    found = check_quadrilateral(np.asarray(points, float), np.ones(4), (480, 640), PolygonLimits())
    if reason is None:
        assert found is None
    else:
        assert reason in found


def test_a_corner_behind_the_camera_is_degenerate():
    matrix = np.array([[1, 0, 0], [0, 1, 0], [-0.02, 0, 1.0]])  # w = 1 - 0.02 x: negative past x = 50
    points, w = geometry_module.project(matrix, SQUARE)
    assert (w <= 0).any()
    assert "infinity" in check_quadrilateral(points, w, (480, 640), PolygonLimits())


def test_homography_methods_are_the_cv2_constants():
    assert [geometry_module.homography_flag(m) for m in geometry_module.HOMOGRAPHY_METHODS] == [
        cv2.RANSAC, cv2.USAC_MAGSAC, cv2.LMEDS, cv2.RHO,
    ]
    with pytest.raises(ValueError, match="unknown homography method"):
        geometry_module.homography_flag("MAGIC")


@pytest.fixture(scope="module")
def poster():
    scene = DemoScene(seed=0)
    return scene, scene.render(0)[0], scene.render(30)[0]


def selected(poster, **parameters) -> FeatureDetector:
    scene, first, _ = poster
    detector = FeatureDetector(**parameters)
    detector.process_area_selection(Rect(*scene.target.reference_rect), first)
    return detector


def test_each_failure_has_its_status_and_reason(poster):
    _, _, frame = poster
    blank = np.full_like(frame, 128)
    detector = selected(poster)
    found = detector.detect(frame)
    assert len(found) == 1 and found.details[0].status is DetectionStatus.FOUND
    result = detector.detect(blank)
    assert result == []
    assert result.details[0].status is DetectionStatus.TOO_FEW_KEYPOINTS
    assert result.reason == (
        "too few keypoints in the frame: 0 ORB keypoints, min_matches is 10 (a plain, dark or blurred frame?)"
    )
    inliers = selected(poster).detect(frame).details[0].inlier_count
    demanding = selected(poster, min_inliers=inliers + 1, min_matches=4).detect(frame)
    assert demanding == [] and demanding.details[0].status is DetectionStatus.TOO_FEW_INLIERS
    assert f"too few inliers: {inliers} of" in demanding.reason
    small = selected(poster, min_area=1e6).detect(frame)
    assert small == [] and small.details[0].status is DetectionStatus.DEGENERATE_POLYGON
    assert small.reason.startswith("degenerate polygon: area")
    assert small.details[0].quadrilateral is not None  # kept for the debug view
    spread = selected(poster, min_inlier_coverage=1.0).detect(frame)
    assert spread == [] and spread.details[0].status is DetectionStatus.BUNCHED_INLIERS
    untrained = FeatureDetector().detect(frame)
    assert untrained == [] and untrained.details[0].status is DetectionStatus.NO_TARGET


def test_a_grey_frame_and_a_colour_frame_give_the_same_result(poster):
    _, _, frame = poster
    detector = selected(poster)
    colour = detector.detect(frame)[0].polygon.xy()
    grey = detector.detect(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))[0].polygon.xy()
    np.testing.assert_allclose(colour, grey)


def test_bad_frames_are_refused_with_a_clear_error(poster):
    detector = selected(poster)
    with pytest.raises(ValueError, match=r"needs an 8-bit image .* got a float32 array of shape"):
        detector.detect(np.zeros((48, 64), np.float32))
    with pytest.raises(SelectionRefused, match="needs an 8-bit image"):
        detector.process_area_selection(Rect(0, 0, 10, 10), None)


def test_switching_the_feature_type_while_a_worker_detects_never_mixes_descriptors(poster):
    """The GUI thread flips ORB/SIFT while frames are processed: every frame either finds the poster where
    it is or reports nothing; no exception, no wrong outline."""
    scene, _, frame = poster
    truth = np.array(scene.render(30)[1]["target"]["corners"])
    detector = selected(poster)
    failures: list[BaseException] = []
    errors: list[float] = []

    def work() -> None:
        try:
            for _ in range(16):
                errors.extend(corner_error(np.array(o.polygon.xy()), truth) for o in detector.detect(frame))
        except BaseException as exc:  # report anything to the main thread
            failures.append(exc)

    worker = threading.Thread(target=work)
    worker.start()
    flips = 0
    while worker.is_alive():
        detector.set_parameters(feature_type="SIFT" if flips % 2 == 0 else "ORB")
        flips += 1
        time.sleep(0.01)
    worker.join()
    assert not failures, failures
    assert flips >= 4
    assert len(errors) == 16 and max(errors) < 3.0  # found every time, always where it is
