"""The whole state in the parameter file: configuration, rectangle and the target image embedded as PNG;
the stored configuration is checked on load, and a target is never matched with another feature type."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from objrec2d import DemoScene, DetectionStatus, FeatureConfig, FeatureDetector
from objrec_core import ParameterFileError, ParameterStorage, RecognitionSystem, Rect, build_system


@pytest.fixture(scope="module")
def scene() -> DemoScene:
    return DemoScene(seed=0)


@pytest.fixture(scope="module")
def frames(scene):
    return [scene.render(i) for i in (0, 45)]


def poster_detector(frames, scene, **parameters) -> FeatureDetector:
    detector = FeatureDetector("poster", object_name="poster", **parameters)
    detector.process_area_selection(Rect(*scene.target.reference_rect), frames[0][0])
    return detector


def save(detector: FeatureDetector, path) -> dict:
    ParameterStorage(RecognitionSystem([detector])).save_parameters(path)
    return yaml.safe_load(path.read_text())


def test_state_round_trips_through_the_file(frames, scene, tmp_path):
    detector = poster_detector(frames, scene, feature_type="SIFT", max_features=500, cross_check=True)
    path = tmp_path / "poster.yaml"
    document = save(detector, path)
    state = document["pipeline"][0]["state"]["target"]
    assert state["features"] == {"type": "SIFT", "max_features": 500, "sift_contrast_threshold": 0.04}
    x, y, width, height = scene.target.reference_rect
    assert state["rect"] == {"x": x, "y": y, "width": width, "height": height}
    assert state["roi"] == {"x": 32, "y": 32, "width": width, "height": height}  # the 32 px margin of context
    assert state["image_encoding"] == "png" and state["image"].startswith(b"\x89PNG")
    assert "!!binary" in path.read_text()

    loaded = build_system(path).detectors[0]
    original, copy = detector.target, loaded.target
    assert (copy.rect, copy.roi, copy.config) == (original.rect, original.roi, original.config)
    assert np.array_equal(copy.image, original.image)  # PNG is lossless
    assert len(copy) == len(original) and np.array_equal(copy.descriptors, original.descriptors)
    assert loaded.object_name == "poster" and loaded.get_parameters() == detector.get_parameters()
    frame = frames[1][0]
    a, b = detector.detect(frame), loaded.detect(frame)
    assert len(a) == len(b) == 1
    np.testing.assert_allclose(a[0].polygon.xy(), b[0].polygon.xy(), atol=1e-6)


def test_a_sift_target_in_a_file_set_to_orb_is_an_error_naming_both(frames, scene, tmp_path):
    path = tmp_path / "poster.yaml"
    document = save(poster_detector(frames, scene, feature_type="SIFT"), path)
    document["pipeline"][0]["parameters"]["feature_type"] = "ORB"  # someone edits the type, not the target
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    with pytest.raises(ParameterFileError) as caught:
        build_system(path)
    message = str(caught.value)
    assert caught.value.key_path == "pipeline[0].state"
    assert "SIFT" in message and "ORB" in message and "select the target again" in message


def test_loading_a_sift_target_into_an_orb_detector_leaves_it_untouched(frames, scene, tmp_path):
    """All or nothing: the running ORB detector keeps its own target when the file is refused."""
    path = tmp_path / "poster.yaml"
    document = save(poster_detector(frames, scene, feature_type="SIFT"), path)
    del document["pipeline"][0]["parameters"]["feature_type"]  # the default, ORB, would be in force
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    running = poster_detector(frames, scene, feature_type="ORB", min_inliers=12)
    before = running.target
    with pytest.raises(ParameterFileError, match="computed with SIFT"):
        ParameterStorage(RecognitionSystem([running])).load_parameters(path)
    assert running.target is before and running.params.min_inliers == 12
    assert running.target.descriptors.dtype == np.uint8


def test_prepare_state_refuses_another_configuration(frames, scene):
    sift = poster_detector(frames, scene, feature_type="SIFT")
    orb = FeatureDetector("poster")
    with pytest.raises(ValueError, match="computed with SIFT"):
        orb.prepare_state(sift.get_state(), orb.get_parameters())
    other_threshold = sift.get_parameters() | {"sift_contrast_threshold": 0.08}
    with pytest.raises(ValueError, match="sift_contrast_threshold"):
        orb.prepare_state(sift.get_state(), other_threshold)
    assert orb.target is None  # preparing changes nothing
    prepared = orb.prepare_state(sift.get_state(), sift.get_parameters())
    assert prepared.target.config == sift.target.config and orb.target is None


def test_changing_the_feature_type_recomputes_the_target_from_its_image(frames, scene):
    detector = poster_detector(frames, scene, feature_type="SIFT")
    sift_target = detector.target
    assert sift_target.descriptors.dtype == np.float32 and sift_target.norm == cv2.NORM_L2
    detector.set_parameters(feature_type="ORB")
    orb_target = detector.target
    assert orb_target is not sift_target and orb_target.config == FeatureConfig.from_parameters(detector.params)
    assert orb_target.descriptors.dtype == np.uint8 and orb_target.norm == cv2.NORM_HAMMING
    assert np.array_equal(orb_target.image, sift_target.image) and orb_target.rect == sift_target.rect
    assert len(detector.detect(frames[1][0])) == 1
    # A matching parameter retrains the matcher but keeps the keypoints.
    detector.set_parameters(matcher="flann", ratio=0.75)
    assert detector.target is orb_target
    assert len(detector.detect(frames[1][0])) == 1
    # A setting of another type does not touch the ORB target.
    detector.set_parameters(sift_contrast_threshold=0.1)
    assert detector.target is orb_target


def test_the_saved_configuration_follows_the_current_parameters(frames, scene, tmp_path):
    detector = poster_detector(frames, scene, feature_type="SIFT")
    detector.set_parameters(feature_type="ORB", orb_levels=6)
    document = save(detector, tmp_path / "poster.yaml")
    assert document["pipeline"][0]["state"]["target"]["features"]["type"] == "ORB"
    assert document["pipeline"][0]["state"]["target"]["features"]["orb_levels"] == 6
    assert build_system(tmp_path / "poster.yaml").detectors[0].target.config.type == "ORB"


def test_no_target_saves_no_state_and_loading_none_clears_it(frames, scene, tmp_path):
    empty = FeatureDetector("poster")
    assert empty.get_state() is None
    save(empty, tmp_path / "empty.yaml")
    assert "state" not in yaml.safe_load((tmp_path / "empty.yaml").read_text())["pipeline"][0]
    loaded = build_system(tmp_path / "empty.yaml").detectors[0]
    assert loaded.target is None
    result = loaded.detect(frames[1][0])
    assert result == [] and result.details[0].status is DetectionStatus.NO_TARGET
    assert result.reason == "no target: select one in objrec-define (drag a rectangle around the object)"
    assert loaded.ready() == result.reason
    running = poster_detector(frames, scene)
    ParameterStorage(RecognitionSystem([running])).load_parameters(tmp_path / "empty.yaml")
    assert running.target is None


def _edit_state(path, edit) -> None:
    document = yaml.safe_load(path.read_text())
    edit(document["pipeline"][0]["state"]["target"])
    path.write_text(yaml.safe_dump(document, sort_keys=False))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda s: s.update(image=b"not a png at all"), "target.image: not a readable"),
        (lambda s: s.update(image="iVBOR"), "target.image: expected PNG bytes"),
        (lambda s: s.update(image_encoding="jpeg"), "only png"),
        (lambda s: s.update(colour="red"), "target.colour: unknown key"),
        (lambda s: s.pop("features"), "target.features: missing"),
        (lambda s: s["roi"].update(x=500), "does not lie inside"),
        (lambda s: s["roi"].update(width=-3), "positive size"),
        (lambda s: s["rect"].update(width="wide"), "expected a whole number"),
    ],
)
def test_a_broken_target_is_reported_with_its_key(frames, scene, tmp_path, edit, message):
    path = tmp_path / "poster.yaml"
    save(poster_detector(frames, scene), path)
    _edit_state(path, edit)
    with pytest.raises(ParameterFileError, match=message) as caught:
        build_system(path)
    assert caught.value.key_path == "pipeline[0].state"


def test_a_feature_type_this_opencv_lacks_is_a_clear_error(tmp_path):
    from objrec2d.features import unavailable_reason

    missing = [t for t in ("SURF", "AKAZE", "BRISK", "KAZE") if unavailable_reason(t)]
    if not missing:
        pytest.skip("this OpenCV has every feature type, SURF included")
    feature_type = missing[0]
    with pytest.raises(ValueError, match=f"{feature_type} .*(not available|cannot be created)"):
        FeatureDetector(feature_type=feature_type)
    path = tmp_path / "surf.yaml"
    path.write_text(
        "format_version: 1\nkind: 2d\npipeline:\n- type: FeatureDetector\n"
        f"  parameters: {{feature_type: {feature_type}}}\n"
    )
    with pytest.raises(ParameterFileError) as caught:
        build_system(path)
    assert caught.value.key_path == "pipeline[0].parameters.feature_type"
    assert "installed OpenCV" in str(caught.value)


def test_the_shipped_demo_file_holds_the_poster(project_root, scene):
    system = build_system(project_root / "params" / "feature_demo.yaml")
    (detector,) = system.detectors
    target = detector.target
    assert target is not None and target.config.type == "ORB"
    assert (target.rect.x, target.rect.y, target.rect.width, target.rect.height) == scene.target.reference_rect
    assert len(target) > 500
