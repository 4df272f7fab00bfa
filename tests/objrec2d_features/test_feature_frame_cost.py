"""The feature detector's per-frame Python, made cheaper without changing an answer: the fast paths give the
same values to the bit as the plain ones they replace, and a found frame makes few NumPy and OpenCV calls.

Counted on the demo's frames with ORB, in ``detect`` alone: before these paths a found frame made about 189
Python-level calls and 258 calls into C functions (NumPy, OpenCV, builtins); now about 62 and 172. Counted with
``sys.setprofile``, never timed (benchmarks/bench_feature.py times them).
"""

from __future__ import annotations

import logging
import math
import sys
import warnings
from collections import Counter
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from objrec2d import DemoScene, FeatureDetector
from objrec2d.base import as_gray
from objrec2d.features import PolygonLimits, check_quadrilateral, rect_corners
from objrec2d.features.geometry import homogeneous_points, project, project_homogeneous
from objrec2d.features.refine import align_photometric, refine_homography, refine_photometric
from objrec_core import Rect


def plain_project(matrix: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``project`` as first written: the stacked homogeneous product, the division silenced throughout."""
    homogeneous = np.hstack([corners.astype(np.float64), np.ones((len(corners), 1))]) @ matrix.T
    w = homogeneous[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return homogeneous[:, :2] / w[:, None], w


def plain_check(points: np.ndarray, w: np.ndarray, frame_shape: tuple[int, ...], limits: PolygonLimits) -> str | None:
    """``check_quadrilateral`` as first written: loops over any number of corners."""
    if min(w.tolist()) <= 1e-9 or not np.all(np.isfinite(points)):
        return "a corner projects to infinity (the homography folds the target behind the camera)"
    pts = [(float(x), float(y)) for x, y in points.tolist()]
    n = len(pts)
    edges = [(pts[(i + 1) % n][0] - pts[i][0], pts[(i + 1) % n][1] - pts[i][1]) for i in range(n)]
    lengths = [math.hypot(ex, ey) for ex, ey in edges]
    if min(lengths) < 1.0:
        return f"a side is shorter than a pixel ({min(lengths):.2f} px)"
    cross = [edges[i][0] * edges[(i + 1) % n][1] - edges[i][1] * edges[(i + 1) % n][0] for i in range(n)]
    if all(c < 0 for c in cross):
        return "mirrored: the homography flips the target over"
    if not all(c > 0 for c in cross):
        return "not convex (the outline crosses itself or bends inwards)"
    area = 0.5 * abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True)))
    if area < limits.min_area:
        return f"area {area:.0f} px² is below min_area {limits.min_area:.0f} px²"
    if area > limits.max_area_fraction * float(frame_shape[0] * frame_shape[1]):
        return f"area {area:.0f} px² is more than {limits.max_area_fraction:g} times the frame's"
    angles = []
    for i in range(n):
        (ax, ay), (bx, by) = edges[i], edges[(i + 1) % n]
        cos = -(ax * bx + ay * by) / (lengths[i] * lengths[(i + 1) % n])
        angles.append(math.degrees(math.acos(max(-1.0, min(1.0, cos)))))
    if min(angles) < limits.min_corner_angle or max(angles) > 180.0 - limits.min_corner_angle:
        return (
            f"a corner angle of {min(angles):.0f}°..{max(angles):.0f}° lies outside "
            f"{limits.min_corner_angle:g}°..{180 - limits.min_corner_angle:g}° (squashed)"
        )
    return None


def random_homography(rng: np.random.Generator, trial: int) -> np.ndarray:
    """Near-identity views, wilder ones, arbitrary matrices and squashing scales in turn: every check's branch."""
    kind = trial % 4
    if kind == 0:
        return np.eye(3) + rng.normal(0, 0.3, (3, 3)) * [[1, 1, 300], [1, 1, 300], [0.002, 0.002, 0]]
    if kind == 1:
        return np.eye(3) + rng.normal(0, 0.05, (3, 3)) * [[1, 1, 300], [1, 1, 300], [0.002, 0.002, 0]]
    if kind == 2:
        return rng.normal(0, 1, (3, 3))
    matrix = np.diag([rng.uniform(0.001, 3), rng.uniform(0.001, 3), 1.0])
    matrix[2, :2] = rng.normal(0, 0.01, 2)
    return matrix


def test_project_and_the_quadrilateral_checks_answer_as_the_plain_code():
    rng = np.random.default_rng(5)
    answers: Counter[str] = Counter()
    for trial in range(8000):
        matrix = random_homography(rng, trial)
        corners = rect_corners(Rect(0, 0, int(rng.integers(2, 400)), int(rng.integers(2, 300))))
        if trial % 2:  # any quadrilateral, so that a bow tie comes through with every w positive
            corners[1:] = rng.uniform(-50, 400, (3, 2))
        points, w = project(matrix, corners)
        plain_points, plain_w = plain_project(matrix, corners)
        assert np.array_equal(points, plain_points, equal_nan=True) and np.array_equal(w, plain_w)
        again, _ = project_homogeneous(matrix, homogeneous_points(corners))
        assert np.array_equal(again, plain_points, equal_nan=True)
        limits = PolygonLimits(rng.uniform(0, 500), rng.uniform(0.1, 5), rng.uniform(0, 60))
        answer = check_quadrilateral(points, w, (480, 640), limits)
        assert answer == plain_check(points, w, (480, 640), limits), trial
        answers[(answer or "plausible").split(" ")[0]] += 1
    # Every branch was taken: plausible, infinity ("a corner projects"), short side ("a side"), mirrored,
    # not convex, too small or too large ("area"), squashed ("a corner angle" also starts with "a").
    assert {"plausible", "a", "mirrored:", "not", "area"} <= set(answers)


def test_a_w_of_zero_is_projected_to_infinity_without_a_warning():
    matrix = np.array([[1.0, 0, 0], [0, 1.0, 0], [-0.01, 0, 1.0]])  # w = 1 - 0.01 x: 0 at x = 100
    corners = np.array([[100.0, 0.0], [0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        points, w = project(matrix, corners)
    assert w[0] == 0.0 and np.isinf(points[0, 0]) and np.array_equal(points[1], [0.0, 0.0])


def test_refine_homography_answers_alike_for_float32_and_float64_points():
    """``findHomography`` works in float32 whichever it is handed, so the refit need not copy the matches'
    float32 positions into float64 (the reprojection widens them exactly)."""
    rng = np.random.default_rng(3)
    truth = np.array([[0.9, 0.1, 40.0], [-0.05, 1.1, 25.0], [1e-4, -2e-4, 1.0]])
    for _ in range(20):
        source = rng.uniform(0, 300, (150, 2)).astype(np.float32)
        destination = (project(truth, source)[0] + rng.normal(0, 0.7, (150, 2))).astype(np.float32)
        destination[:30] += rng.uniform(-40, 40, (30, 2)).astype(np.float32)  # outliers
        start = truth + rng.normal(0, 1e-3, (3, 3)) * [[1, 1, 100], [1, 1, 100], [1e-3, 1e-3, 0]]
        inliers = np.hypot(*(project(start, source)[0] - destination).T) < 3.0
        single, single_mask = refine_homography(source, destination, start, inliers, 3.0)
        double, double_mask = refine_homography(source.astype(np.float64), destination.astype(np.float64), start,
                                                inliers, 3.0)
        assert np.array_equal(single, double) and np.array_equal(single_mask, double_mask)
        assert single_mask.sum() >= inliers.sum()


@pytest.fixture(scope="module")
def demo() -> tuple[FeatureDetector, list[np.ndarray]]:
    """ORB on the demo poster, with a few of the demo's frames (every 25th, the poster in several poses)."""
    scene = DemoScene(seed=0)
    first, _ = scene.render(0)
    detector = FeatureDetector(feature_type="ORB")
    detector.process_area_selection(Rect(*scene.target.reference_rect), first)
    return detector, [scene.render(25 * i)[0] for i in range(1, 5)]


def test_the_alignment_given_the_outline_answers_as_refine_photometric(demo):
    """The detector hands ``align_photometric`` the outline it has projected and takes back the refined one:
    the same homography as ``refine_photometric`` and the outline ``project`` gives, to the bit."""
    detector, frames = demo
    target = detector.target
    roi = target.roi
    box = (roi.x, roi.y, roi.width, roi.height)
    for frame in frames:
        found = detector.detect(frame).details[0]
        assert found.found
        gray = as_gray(frame)
        nudged = found.homography @ np.array([[1.0, 0.0, 1.5], [0.0, 1.0, -1.0], [0.0, 0.0, 1.0]])
        start, _ = project(nudged, target.corners())
        alone, why = refine_photometric(target.gray, box, gray, nudged, 6.0)
        refined, outline, why_too = align_photometric(target.gray, box, gray, nudged, 6.0, start=start)
        assert alone is not None and refined is not None and outline is not None and why == why_too == ""
        assert np.array_equal(alone, refined)
        points, w = project(refined, target.corners())
        assert np.array_equal(outline[0], points) and np.array_equal(outline[1], w)


def calls_per_frame(detect: Callable[[np.ndarray], Any], frames: list[np.ndarray]) -> tuple[float, float]:
    """Python-level calls and calls into C functions (NumPy's, OpenCV's, builtins) per ``detect``."""
    counts: Counter[str] = Counter()

    def profile(frame: Any, event: str, arg: Any) -> None:
        if event in ("call", "c_call"):
            counts[event] += 1

    sys.setprofile(profile)
    try:
        for frame in frames:
            detect(frame)
    finally:
        sys.setprofile(None)
    return counts["call"] / len(frames), counts["c_call"] / len(frames)


def test_a_found_frame_makes_few_calls(demo):
    """Before the fast paths a found demo frame made about 189 Python-level calls and 258 C calls; now about
    62 and 172 (they may move by a few with the NumPy version, hence the margin)."""
    detector, frames = demo
    for frame in frames:
        assert detector.detect(frame)  # found, and the per-snapshot settings made, before counting
    package = logging.getLogger("objrec2d")
    level = package.level
    package.setLevel(logging.INFO)  # a run logging at DEBUG (log_cli) would count the logging machinery too
    try:
        python, native = calls_per_frame(detector.detect, frames)
    finally:
        package.setLevel(level)
    assert python <= 100, python
    assert native <= 210, native


def test_a_parameter_change_reaches_the_next_frame(demo):
    """The settings a snapshot decides are made once per snapshot: a change takes effect at the next frame."""
    detector, frames = demo
    assert detector.detect(frames[0])
    detector.set_parameters(min_area=1e7)
    try:
        refused = detector.detect(frames[0])
        assert not refused and "below min_area" in refused.reason
    finally:
        detector.set_parameters(min_area=100.0)
    assert detector.detect(frames[0])
