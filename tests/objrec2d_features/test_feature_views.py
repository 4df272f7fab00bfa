"""Debug views (the side-by-side match view and keypoints on the frame) and the headless app on the shipped
demo file."""

from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from objrec2d import DemoScene, FeatureDetector
from objrec2d.features import debug
from objrec_core import DefinitionDirector, RecognitionSystem, Rect


@pytest.fixture(scope="module")
def scene_frames():
    scene = DemoScene(seed=0)
    return scene, scene.render(0)[0], scene.render(40)


def colour_pixels(image: np.ndarray, colour: tuple[int, int, int]) -> int:
    return int(np.all(image == np.array(colour, np.uint8), axis=2).sum())


def test_side_by_side_shows_frame_target_matches_and_polygon(scene_frames):
    scene, first, (frame, truth) = scene_frames
    detector = FeatureDetector()
    detector.process_area_selection(Rect(*scene.target.reference_rect), first)
    objects = detector.detect(frame)
    assert len(objects) == 1
    view = detector.render_debug(frame, objects)
    target = detector.target.image
    assert view.shape == (max(frame.shape[0], target.shape[0]), frame.shape[1] + target.shape[1], 3)
    right = view[: target.shape[0], frame.shape[1] :]
    assert np.mean(right == target) > 0.5  # the target image, under its keypoints and the match lines
    assert colour_pixels(view, debug.INLIER) > 1000  # green lines from frame to target
    left = view[:, : frame.shape[1]]
    corners = np.array(truth["target"]["corners"])
    for x, y in np.round(corners).astype(int):  # the polygon (yellow) runs through the true corners
        patch = left[max(y - 3, 0) : y + 4, max(x - 3, 0) : x + 4]
        assert colour_pixels(patch, debug.FOUND) > 0


def test_outliers_are_drawn_in_their_own_colour(scene_frames):
    scene, first, (frame, _) = scene_frames
    detector = FeatureDetector(ratio_test=False)  # keeps ambiguous matches, many of them wrong
    detector.process_area_selection(Rect(*scene.target.reference_rect), first)
    objects = detector.detect(frame)
    result = objects.details[0]
    assert (~result.inliers).sum() > 50
    assert colour_pixels(detector.render_debug(frame, objects), debug.OUTLIER) > 500


def test_keypoints_view_and_views_without_a_result(scene_frames):
    scene, first, (frame, _) = scene_frames
    detector = FeatureDetector(debug_view="keypoints")
    empty = detector.render_debug(frame, [])
    assert empty.shape == frame.shape  # no target: the frame and a status line
    detector.process_area_selection(Rect(*scene.target.reference_rect), first)
    objects = detector.detect(frame)
    view = detector.render_debug(frame, objects)
    assert view.shape == frame.shape and colour_pixels(view, debug.KEYPOINT) > 500
    small = cv2.resize(frame, (320, 240))
    detector.set_parameters(debug_view="side_by_side")
    assert detector.render_debug(small, []).shape[0] == max(240, detector.target.image.shape[0])  # no stale points


def test_the_definition_director_hands_the_view_to_the_gui(scene_frames):
    scene, first, (frame, _) = scene_frames
    detector = FeatureDetector("poster")
    director = DefinitionDirector(RecognitionSystem([detector]))
    director.process(first)
    assert director.process_area_selection(Rect(*scene.target.reference_rect)).accepted == ["poster"]
    results = director.process(frame)
    (stage,) = [s for s in results.stages if s.role == "detector"]
    assert stage.debug is not None and stage.debug.shape[1] == frame.shape[1] + detector.target.image.shape[1]
    assert len(results.objects.objects) == 1


@pytest.mark.slow
def test_objrec_detect_finds_the_poster_frame_after_frame(project_root):
    completed = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", str(project_root / "params" / "feature_demo.yaml"),
         "--source", "demo", "--max-frames", "40", "--no-progress"],
        capture_output=True, text=True, timeout=120, cwd=project_root, check=False,
    )
    assert completed.returncode == 0, completed.stderr
    lines = [json.loads(line) for line in completed.stdout.splitlines()]
    assert len(lines) == 40
    assert all([o["name"] for o in line["objects"]] == ["poster"] for line in lines)
    assert all(len(line["objects"][0]["polygon"]["points"]) == 4 for line in lines)
