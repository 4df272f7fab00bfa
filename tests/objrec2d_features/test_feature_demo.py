"""The demo's textured poster: ground truth, a layout that leaves the colour system alone, and corner
error against the truth of at most 3 px in 95 % of frames."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from objrec2d import BinaryDetector, DemoScene, FeatureDetector, HSVFilter, MorphologyFilter
from objrec2d.demo import FPS
from objrec2d.features import corner_error
from objrec_core import DetectionDirector, Frame, RecognitionSystem, Rect, build_system


def share_within(errors: list[float], limit: float = 3.0) -> float:
    return float(np.mean(np.asarray(errors) <= limit))


def run_and_measure(system: RecognitionSystem, seed: int, indices: range) -> list[float]:
    """Largest corner error per frame (infinite where the poster was not reported exactly once)."""
    scene = DemoScene(seed=seed)
    director = DetectionDirector(system)
    errors = []
    for index in indices:
        image, truth = scene.render(index)
        objects = director.process(Frame(image, index=index, truth=truth)).objects
        if len(objects) != 1:
            errors.append(np.inf)
            continue
        errors.append(corner_error(np.array(objects[0].polygon.xy()), truth["target"]["corners"]))
    return errors


def test_frame_zero_shows_the_poster_head_on_on_its_reference_rect():
    scene = DemoScene(seed=0)
    _, truth = scene.render(0)
    x, y, width, height = scene.target.reference_rect
    left, top, right, bottom = x - 0.5, y - 0.5, x + width - 0.5, y + height - 0.5
    expected = [[left, top], [right, top], [right, bottom], [left, bottom]]
    np.testing.assert_allclose(truth["target"]["corners"], expected, atol=1e-9)
    np.testing.assert_allclose(truth["target"]["homography"], [[1, 0, x], [0, 1, y], [0, 0, 1]], atol=1e-12)


def test_the_poster_moves_turns_and_tilts():
    target = DemoScene(seed=0).target
    poses = [target.homography(i / FPS) for i in range(0, 900, 5)]
    turns = [np.degrees(np.arctan2(h[1, 0], h[0, 0])) for h in poses]
    perspective = [np.hypot(h[2, 0], h[2, 1]) for h in poses]
    centres = np.array([target.corners(i / FPS).mean(axis=0) for i in range(0, 900, 5)])
    assert max(turns) - min(turns) > 40  # degrees
    assert max(perspective) > 3e-4  # a visible keystone, not only a similarity
    assert np.ptp(centres[:, 0]) > 60 and np.ptp(centres[:, 1]) > 120


def test_the_poster_never_comes_near_a_coloured_object_and_stays_grey():
    scene = DemoScene(seed=0)
    for index in range(0, 3600, 3):  # two minutes of the scene
        t = index / FPS
        poster = scene.target.corners(t)
        for obj in scene.objects:
            outline = obj.outline(t)
            if obj.home[0] < 320:
                gap = poster[:, 0].min() - outline[:, 0].max()
            else:
                gap = outline[:, 0].min() - poster[:, 0].max()
            assert gap > 25, (index, obj.name, gap)
    for index in range(0, 300, 25):
        image, truth = scene.render(index)
        mask = np.zeros(image.shape[:2], np.uint8)
        cv2.fillPoly(mask, [np.round(np.array(truth["target"]["corners"])).astype(np.int32)], 255)
        hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
        lit = (mask > 0) & (hsv[:, :, 2] >= 60)  # the colour system ignores darker pixels (v_min 60)
        assert hsv[:, :, 1][lit].max() < 110  # s_min is 120; single noisy pixels reach about 100


def test_the_colour_system_still_finds_exactly_the_four_shapes_with_the_poster_there():
    system = RecognitionSystem(
        [HSVFilter(h_min=0, h_max=179, s_min=120, v_min=60), MorphologyFilter(), BinaryDetector()]
    )
    director = DetectionDirector(system)
    scene = DemoScene(seed=0)
    for index in range(0, 300, 10):
        image, truth = scene.render(index)
        objects = director.process(image).objects
        assert len(objects) == 4, index
        for shape in truth["objects"]:
            nearest = min(np.hypot(*(np.array(o.polygon.centroid()) - shape["centroid"])) for o in objects)
            assert nearest < 3.0


@pytest.mark.slow
def test_the_shipped_demo_file_keeps_the_corners_within_3px_in_95_percent_of_frames(project_root):
    system = build_system(project_root / "params" / "feature_demo.yaml")
    errors = run_and_measure(system, 0, range(300))  # ten seconds of the scene
    assert share_within(errors) >= 0.95, np.percentile(errors, [50, 90, 95])
    assert np.isfinite(errors).all()  # found in every frame
    # Another background (the poster is the same object whatever the random seed), other moments.
    assert share_within(run_and_measure(system, 7, range(300, 900, 10))) >= 0.95


@pytest.mark.slow
@pytest.mark.parametrize("feature_type", ["SIFT", "AKAZE"])
def test_other_feature_types_keep_the_corners_within_3px_in_95_percent_of_frames(require_feature, feature_type):
    require_feature(feature_type)
    scene = DemoScene(seed=0)
    frame, _ = scene.render(0)
    detector = FeatureDetector(feature_type=feature_type)
    detector.process_area_selection(Rect(*scene.target.reference_rect), frame)
    errors = run_and_measure(RecognitionSystem([detector]), 0, range(0, 300, 5))
    assert len(errors) == 60
    assert share_within(errors) >= 0.95, np.percentile(errors, [50, 90, 95])
