"""Area selections: a textured one becomes the target; a plain, tiny or misplaced one is refused with a
reason the GUI can show, and the previous target stays."""

from __future__ import annotations

import numpy as np
import pytest

from objrec2d import DemoScene, FeatureDetector
from objrec_core import Change, DefinitionDirector, RecognitionSystem, Rect, SelectionRefused


def plain_frame(seed: int = 1) -> np.ndarray:
    """A grey wall with a little sensor noise and nothing on it."""
    rng = np.random.default_rng(seed)
    return np.clip(rng.normal(150, 2.0, size=(240, 320, 3)), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("feature_type", ["ORB", "SIFT"])
def test_a_textureless_selection_is_refused_with_a_reason(feature_type):
    detector = FeatureDetector(feature_type=feature_type)
    with pytest.raises(SelectionRefused) as caught:
        detector.process_area_selection(Rect(60, 40, 150, 120), plain_frame())
    reason = str(caught.value)
    assert f"no {feature_type} keypoints" in reason and "too plain" in reason and "10 are needed" in reason
    assert detector.target is None


@pytest.mark.realdata
def test_a_bare_wall_in_a_real_photo_is_refused(images):
    import cv2

    scene = cv2.imread(str(images / "multi_scene.jpg"))
    with pytest.raises(SelectionRefused, match="too plain"):
        FeatureDetector(feature_type="ORB").process_area_selection(Rect(0, 0, 90, 250), scene)


@pytest.mark.parametrize(
    ("rect", "message"),
    [
        (Rect(2000, 10, 50, 50), "outside"),
        (Rect(10, 10, 4, 40), "select at least 8x8"),
        (Rect(-40, -40, 44, 44), "select at least 8x8"),  # what is left inside the frame is 4x4
    ],
)
def test_a_selection_too_small_or_outside_is_refused(rect, message):
    with pytest.raises(SelectionRefused, match=message):
        FeatureDetector().process_area_selection(rect, plain_frame())


def test_the_minimum_follows_min_matches_and_min_inliers():
    scene = DemoScene(seed=0)
    frame, _ = scene.render(0)
    x, y, _, _ = scene.target.reference_rect
    small = Rect(x + 20, y + 20, 40, 30)  # a corner of the poster: a few dozen ORB keypoints
    probe = FeatureDetector(min_matches=4, min_inliers=4)
    probe.process_area_selection(small, frame)
    count = len(probe.target)
    assert 4 <= count < 500
    with pytest.raises(SelectionRefused, match=f"only {count} ORB keypoints, {count + 1} are needed"):
        FeatureDetector(min_inliers=count + 1).process_area_selection(small, frame)
    FeatureDetector(min_matches=count).process_area_selection(small, frame)  # exactly enough


def test_a_refused_selection_keeps_the_previous_target_and_reaches_the_gui_through_the_director():
    scene = DemoScene(seed=0)
    frame, _ = scene.render(0)
    detector = FeatureDetector("poster")
    director = DefinitionDirector(RecognitionSystem([detector]))
    first = director.process_area_selection(Rect(*scene.target.reference_rect))
    assert first.accepted == [] and "no frame" in first.refused["poster"]
    director.process(frame)
    accepted = director.process_area_selection(Rect(*scene.target.reference_rect))
    assert accepted.accepted == ["poster"] and accepted.refused == {}
    target = detector.target
    refused = director.process_area_selection(Rect(0, 0, 6, 6))
    assert refused.accepted == [] and "select at least" in refused.refused["poster"]
    assert detector.target is target


def test_observers_hear_of_a_new_target_as_a_state_change():
    scene = DemoScene(seed=0)
    frame, _ = scene.render(0)
    detector = FeatureDetector()
    heard = []
    detector.watch(lambda changes: heard.append(list(changes)))
    states = []
    detector.watch(lambda changes: states.append(list(changes)), names={"state"})
    parameters = []
    detector.watch(lambda changes: parameters.append(list(changes)), names={"min_inliers"})
    detector.process_area_selection(Rect(*scene.target.reference_rect), frame)
    assert heard == [[Change(detector, "state")]] and states == heard and parameters == []
    with pytest.raises(SelectionRefused):
        detector.process_area_selection(Rect(0, 0, 4, 4), frame)
    assert len(heard) == 1  # a refused selection changes nothing, so nobody hears of it
    detector.clear_target()
    assert detector.target is None and heard == [[Change(detector, "state")]] * 2 and states == heard
    detector.set_parameters(min_inliers=12)
    assert heard[-1] == [Change(detector, "min_inliers", 10, 12)] and len(states) == 2
    assert parameters == [[Change(detector, "min_inliers", 10, 12)]]
