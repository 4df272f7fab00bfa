"""Refined homographies: every feature type places the found outline within 2 px (in practice well under 1 px)
on pasted copies of box.png with known homographies, on box_in_scene.png against a SIFT + photometric reference,
and on the central part of graf1 -> graf3 against the Oxford set's own homography.

The composites are made here from seeds no tuning run ever saw (the refinement was developed on seeds
1000-1009 of another generator), so the figures are not fitted to them.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec2d import FeatureDetector
from objrec2d.features import FEATURE_TYPES, corner_error, rect_corners, unavailable_reason
from objrec2d.features.geometry import project
from objrec2d.features.refine import refine_homography, refine_photometric
from objrec_core import Rect

AVAILABLE = [t for t in FEATURE_TYPES if unavailable_reason(t) is None]
#: The Oxford affine set's graf 1 -> 3 homography (H1to3p, as OpenCV's samples ship it).
GRAF_H1TO3 = np.array([[7.6285898e-01, -2.9922929e-01, 2.2567123e02],
                       [3.3443473e-01, 1.0143901e00, -7.6999973e01],
                       [3.4663091e-04, -1.4364524e-05, 1.0]])


def textured_background(rng: np.random.Generator, height: int = 480, width: int = 640) -> np.ndarray:
    """Blurred colour noise: busy enough for keypoints everywhere, unlike any part of the box."""
    noise = rng.integers(0, 256, (height // 8, width // 8, 3), dtype=np.uint8)
    return cv2.GaussianBlur(cv2.resize(noise, (width, height), interpolation=cv2.INTER_CUBIC), (0, 0), 2)


def random_view(rng: np.random.Generator, size: tuple[int, int], centre: tuple[float, float]) -> np.ndarray:
    """A homography taking a ``size`` (w, h) picture to a view scaled 0.6-1.2x, turned up to 40 degrees and
    tilted (each corner moved up to 12 % of the side) around ``centre``."""
    w, h = size
    src = rect_corners(Rect(0, 0, w, h))
    turn = cv2.getRotationMatrix2D((0.0, 0.0), rng.uniform(-40, 40), rng.uniform(0.6, 1.2))[:, :2]
    dst = (src - [w / 2, h / 2]) @ turn.T + centre
    dst += rng.uniform(-0.12, 0.12, (4, 2)) * np.abs(turn).sum(axis=1) * [w, h]
    return cv2.getPerspectiveTransform(src, dst.astype(np.float32))


def paste(frame: np.ndarray, picture: np.ndarray, homography: np.ndarray) -> np.ndarray:
    """``picture`` drawn into ``frame`` through ``homography`` (pixel centres to pixel centres), edges blended."""
    size = (frame.shape[1], frame.shape[0])
    warped = cv2.warpPerspective(picture, homography, size, flags=cv2.INTER_LINEAR)
    alpha = cv2.warpPerspective(np.full(picture.shape[:2], 255, np.uint8), homography, size, flags=cv2.INTER_LINEAR)
    alpha = (alpha.astype(np.float32) / 255.0)[..., None]
    return (warped * alpha + frame * (1.0 - alpha)).astype(np.uint8)


def composite(box: np.ndarray, seed: int, centres: list[tuple[float, float]]) -> tuple[np.ndarray, list[np.ndarray]]:
    rng = np.random.default_rng(seed)
    frame = textured_background(rng)
    views = []
    for centre in centres:
        view = random_view(rng, (box.shape[1], box.shape[0]), centre)
        frame = paste(frame, box, view)
        views.append(view)
    return frame, views


def outlines(objects) -> list[np.ndarray]:
    return [np.array(o.polygon.xy()) for o in objects]


@pytest.mark.realdata
@pytest.mark.parametrize("feature_type", AVAILABLE)
def test_every_type_places_pasted_copies_of_the_box_within_a_pixel(box, feature_type):
    detector = FeatureDetector(feature_type=feature_type, object_name="box")
    detector.set_target(box)
    truth_corners = detector.target.corners()
    errors = []
    for seed in (24_001, 24_002, 24_003):
        rng = np.random.default_rng(seed)
        frame, (view,) = composite(box, seed, [(rng.uniform(260, 380), rng.uniform(200, 280))])
        (found,) = outlines(detector.detect(frame))
        errors.append(corner_error(found, project(view, truth_corners)[0]))
    assert max(errors) < 1.0, errors  # the promised bound is 2 px; ORB's keypoint fit alone was 7.1 px off


@pytest.mark.realdata
def test_three_copies_in_one_frame_are_each_placed_within_a_pixel_by_orb(box):
    small = cv2.resize(box, None, fx=0.55, fy=0.55, interpolation=cv2.INTER_AREA)
    detector = FeatureDetector(feature_type="ORB", object_name="box", max_instances=3)
    detector.set_target(small)
    frame, views = composite(small, 24_010, [(140.0, 130.0), (480.0, 140.0), (320.0, 360.0)])
    found = outlines(detector.detect(frame))
    assert len(found) == 3
    truths = [project(view, detector.target.corners())[0] for view in views]
    errors = sorted(min(corner_error(f, t) for t in truths) for f in found)
    assert errors[-1] < 1.0, errors


def box_reference(box: np.ndarray, scene: np.ndarray) -> np.ndarray:
    """The box's outline in box_in_scene.png, computed here independently of the detector: SIFT matches with
    Lowe's ratio 0.75, RANSAC (3 px), a least-squares refit on its inliers, then OpenCV's correlation alignment
    of the whole box.png at full resolution run to convergence (500 iterations, epsilon 1e-8)."""
    grey_box, grey_scene = cv2.cvtColor(box, cv2.COLOR_BGR2GRAY), cv2.cvtColor(scene, cv2.COLOR_BGR2GRAY)
    sift = cv2.SIFT_create()
    kb, db = sift.detectAndCompute(grey_box, None)
    ks, ds = sift.detectAndCompute(grey_scene, None)
    good = [a for a, b in cv2.BFMatcher().knnMatch(db, ds, k=2) if a.distance < 0.75 * b.distance]
    src = np.float32([kb[m.queryIdx].pt for m in good])
    dst = np.float32([ks[m.trainIdx].pt for m in good])
    homography, mask = cv2.findHomography(src, dst, cv2.RANSAC, 3.0)
    inliers = mask.ravel() > 0
    homography, _ = cv2.findHomography(src[inliers], dst[inliers], 0)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 500, 1e-8)
    correlation, warp = cv2.findTransformECC(grey_box, grey_scene, homography.astype(np.float32),
                                             cv2.MOTION_HOMOGRAPHY, criteria, None, 3)
    assert correlation > 0.75 and inliers.sum() > 50
    return project(warp.astype(np.float64), rect_corners(Rect(0, 0, box.shape[1], box.shape[0])))[0]


@pytest.mark.realdata
def test_the_reference_outline_agrees_with_the_hand_checked_one(box, box_in_scene):
    hand_checked = np.array([[118.7, 160.8], [284.8, 174.9], [267.7, 298.3], [89.3, 272.1]])  # test_feature_box.py
    assert corner_error(box_reference(box, box_in_scene), hand_checked) < 1.5


@pytest.mark.realdata
@pytest.mark.parametrize("feature_type", AVAILABLE)
def test_every_type_finds_the_box_in_the_scene_within_a_pixel_of_the_reference(box, box_in_scene, feature_type):
    reference = box_reference(box, box_in_scene)
    detector = FeatureDetector(feature_type=feature_type, object_name="box")
    detector.set_target(box)
    (found,) = outlines(detector.detect(box_in_scene))
    assert corner_error(found, reference) < 1.0  # 0.44-0.56 px; ORB's keypoint fit alone was 7.8 px off


@pytest.mark.realdata
@pytest.mark.parametrize("feature_type", AVAILABLE)
def test_graf_central_selection_within_two_pixels_of_the_oxford_homography(images: Path, feature_type):
    paths = [images / "graf1.png", images / "graf3.png"]
    missing = [p.name for p in paths if not p.is_file()]
    if missing:
        pytest.skip(f"{', '.join(missing)} not in {images} (OpenCV's samples/data has them)")
    graf1, graf3 = (cv2.imread(str(p)) for p in paths)
    height, width = graf1.shape[:2]
    selection = Rect(width // 4, height // 4, width // 2, height // 2)
    detector = FeatureDetector(feature_type=feature_type, object_name="graffiti", max_features=3000)
    detector.set_target(graf1, selection)
    (found,) = outlines(detector.detect(graf3))
    truth = project(GRAF_H1TO3, rect_corners(selection))[0]
    assert corner_error(found, truth) <= 2.0


# -- the refinement's parts ---------------------------------------------------------------------------------
def test_the_refit_takes_back_inliers_the_robust_fit_left_out_and_never_loses_any():
    rng = np.random.default_rng(8)
    truth = np.array([[1.1, 0.1, 10.0], [-0.1, 0.95, 30.0], [1e-4, 2e-4, 1.0]])
    source = rng.uniform(0, 200, (120, 2))
    destination = project(truth, source)[0] + rng.normal(0.0, 0.5, (120, 2))
    destination[:20] += rng.uniform(20, 60, (20, 2))  # 20 wrong matches
    start = truth.copy()
    start[0, 2] += 2.5  # a robust fit 2.5 px off, which left some good matches out
    first = np.hypot(*(project(start, source)[0] - destination).T) < 3.0
    refined, inliers = refine_homography(source, destination, start, first, 3.0)
    assert inliers.sum() >= first.sum() and inliers[20:].all() and not inliers[:20].any()
    corners = rect_corners(Rect(0, 0, 200, 200))
    assert corner_error(project(refined, corners)[0], project(truth, corners)[0]) < 0.5


def test_the_photometric_alignment_is_refused_where_the_target_is_not_there(box):
    grey = cv2.cvtColor(box, cv2.COLOR_BGR2GRAY)
    frame, (view,) = composite(box, 24_020, [(320.0, 240.0)])
    frame_grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    roi = (0, 0, grey.shape[1], grey.shape[0])
    nudged = np.array([[1, 0, 1.5], [0, 1, -1.0], [0, 0, 1]]) @ view
    refined, why = refine_photometric(grey, roi, frame_grey, nudged, 6.0)
    assert refined is not None and why == ""
    corners = rect_corners(Rect(*roi))
    assert corner_error(project(refined, corners)[0], project(view, corners)[0]) < 0.3
    blank = np.full_like(frame_grey, 128)
    blank[::7] = 0  # stripes, nothing like the box
    refused, why = refine_photometric(grey, roi, blank, view, 6.0)
    assert refused is None and why.startswith("the photometric alignment")
