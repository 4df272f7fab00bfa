"""The homography from target to frame, and the checks a projected target must pass to count as found.

A homography fitted to a handful of lucky matches can fold the target rectangle into a bow tie, squash it
to a line or blow it up past the frame; find-object rejects such results before reporting anything, and so
do we.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from objrec_core import Rect

from .types import FeatureUnavailable

#: Homography estimators by the name used in parameter files (the cv2 constant of the same name).
HOMOGRAPHY_METHODS: tuple[str, ...] = ("RANSAC", "USAC_MAGSAC", "LMEDS", "RHO")

_FLAGS: dict[str, int] = {}  # the constants looked up so far: estimate_homography asks every frame


def homography_flag(method: str) -> int:
    """The cv2 constant for a method name; USAC methods need OpenCV 4.5 or newer."""
    flag = _FLAGS.get(method)
    if flag is not None:
        return flag
    if method not in HOMOGRAPHY_METHODS:
        raise ValueError(f"unknown homography method {method!r} (known: {', '.join(HOMOGRAPHY_METHODS)})")
    flag = getattr(cv2, method, None)
    if flag is None:
        raise FeatureUnavailable(f"homography method {method} is not in the installed OpenCV {cv2.__version__}")
    _FLAGS[method] = int(flag)
    return int(flag)


def unavailable_homography_methods() -> dict[str, str]:
    """``{method: reason}`` for the methods this OpenCV lacks (the ``unavailable`` of ``homography_method``)."""
    missing = {}
    for method in HOMOGRAPHY_METHODS:
        try:
            homography_flag(method)
        except FeatureUnavailable as exc:
            missing[method] = str(exc)
    return missing


def rect_corners(rect: Rect) -> np.ndarray:
    """The rectangle's outline as 4 x 2 float32, clockwise on screen from the top-left.

    OpenCV puts pixel centres on integer coordinates, so the outer edge of pixel column ``x`` is at
    ``x - 0.5``: these are the corners of the pixels' outline, not the centres of the corner pixels, so
    that a transformed rectangle outlines the object however it is scaled or turned.
    """
    x0, y0 = rect.x - 0.5, rect.y - 0.5
    x1, y1 = x0 + rect.width, y0 + rect.height
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float32)


def estimate_homography(
    target_points: np.ndarray,
    frame_points: np.ndarray,
    method: str,
    threshold: float,
    max_iterations: int = 2000,
    confidence: float = 0.995,
) -> tuple[np.ndarray | None, np.ndarray]:
    """Fit target -> frame; returns the 3x3 matrix (None where none was found) and the inlier mask."""
    count = len(target_points)
    if count < 4:
        return None, np.zeros(count, dtype=bool)
    try:
        matrix, mask = cv2.findHomography(
            target_points.reshape(-1, 1, 2),
            frame_points.reshape(-1, 1, 2),
            homography_flag(method),
            threshold,
            maxIters=max_iterations,
            confidence=confidence,
        )
    except cv2.error:  # e.g. all points on one line: no homography, which is a failure, not a crash
        return None, np.zeros(count, dtype=bool)
    if matrix is None or mask is None or not np.isfinite(matrix).all():
        return None, np.zeros(count, dtype=bool)
    return matrix, mask.reshape(-1).astype(bool)


@dataclass(frozen=True)
class PolygonLimits:
    """What a plausible projected target looks like."""

    min_area: float = 100.0  # square pixels
    max_area_fraction: float = 4.0  # of the frame's area
    min_corner_angle: float = 15.0  # degrees; the largest angle may be at most 180 minus this


def project(matrix: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corners through the homography: the projected points and their homogeneous w (w <= 0: behind)."""
    return project_homogeneous(matrix, homogeneous_points(corners))


def homogeneous_points(points: np.ndarray) -> np.ndarray:
    """``points`` (N x 2) as N x 3 float64 rows (x, y, 1), for ``project_homogeneous``."""
    homogeneous = np.empty((len(points), 3))
    homogeneous[:, :2] = points
    homogeneous[:, 2] = 1.0
    return homogeneous


def project_homogeneous(matrix: np.ndarray, homogeneous: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``project`` of points given as N x 3 float64 rows (x, y, 1) (``homogeneous_points``): points projected
    again and again (a target's outline, every frame) are made homogeneous once. The same product and
    division as ``project``, to the bit."""
    projected = homogeneous @ matrix.T
    w = projected[:, 2]
    if w.all() and np.isfinite(w).all():  # nothing to divide by zero: silencing NumPy costs more than dividing
        return projected[:, :2] / w[:, None], w
    with np.errstate(divide="ignore", invalid="ignore"):
        return projected[:, :2] / w[:, None], w


def check_quadrilateral(
    points: np.ndarray, w: np.ndarray, frame_shape: tuple[int, ...], limits: PolygonLimits
) -> str | None:
    """None where the projected rectangle (4 corners) is a plausible view of a flat object, else what is wrong.

    Plain floats from one ``tolist``, written out corner by corner: for four points numpy's call overhead,
    and even Python's loops and generators, cost more than the arithmetic, and this runs twice on every
    frame a copy is found.
    """
    isfinite, hypot = math.isfinite, math.hypot
    (x0, y0), (x1, y1), (x2, y2), (x3, y3) = points.tolist()
    if min(w.tolist()) <= 1e-9 or not (
        isfinite(x0) and isfinite(y0) and isfinite(x1) and isfinite(y1)
        and isfinite(x2) and isfinite(y2) and isfinite(x3) and isfinite(y3)
    ):
        return "a corner projects to infinity (the homography folds the target behind the camera)"
    # Edge i runs from corner i to corner i + 1.
    ax, ay, bx, by, cx, cy, dx, dy = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x3 - x2, y3 - y2, x0 - x3, y0 - y3
    la, lb, lc, ld = hypot(ax, ay), hypot(bx, by), hypot(cx, cy), hypot(dx, dy)
    shortest = min(la, lb, lc, ld)
    if shortest < 1.0:
        return f"a side is shorter than a pixel ({shortest:.2f} px)"
    ab, bc, cd, da = ax * by - ay * bx, bx * cy - by * cx, cx * dy - cy * dx, dx * ay - dy * ax
    if ab < 0 and bc < 0 and cd < 0 and da < 0:
        return "mirrored: the homography flips the target over"
    if not (ab > 0 and bc > 0 and cd > 0 and da > 0):
        return "not convex (the outline crosses itself or bends inwards)"
    area = 0.5 * abs(x0 * y1 - x1 * y0 + (x1 * y2 - x2 * y1) + (x2 * y3 - x3 * y2) + (x3 * y0 - x0 * y3))
    if area < limits.min_area:
        return f"area {area:.0f} px² is below min_area {limits.min_area:.0f} px²"
    frame_area = float(frame_shape[0] * frame_shape[1])
    if area > limits.max_area_fraction * frame_area:
        return f"area {area:.0f} px² is more than {limits.max_area_fraction:g} times the frame's"
    # The interior angle at corner i + 1 lies between the reversed edge i and edge i + 1.
    angles = (
        _angle(-(ax * bx + ay * by) / (la * lb)),
        _angle(-(bx * cx + by * cy) / (lb * lc)),
        _angle(-(cx * dx + cy * dy) / (lc * ld)),
        _angle(-(dx * ax + dy * ay) / (ld * la)),
    )
    if min(angles) < limits.min_corner_angle or max(angles) > 180.0 - limits.min_corner_angle:
        return (
            f"a corner angle of {min(angles):.0f}°..{max(angles):.0f}° lies outside "
            f"{limits.min_corner_angle:g}°..{180 - limits.min_corner_angle:g}° (squashed)"
        )
    return None


def _angle(cos: float) -> float:
    """The angle in degrees of a cosine that rounding may have pushed past +-1."""
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def inlier_coverage(target_points: np.ndarray, roi_area: float) -> float:
    """The share of the selection covered by the convex hull of the inliers' target positions.

    A homography fitted to points along one line (a bar, a row of text) or in one small patch fits
    them well and still swings the far corners about: it is only trustworthy where the inliers span
    a fair part of the target.
    """
    if len(target_points) < 3 or roi_area <= 0:
        return 0.0
    hull = cv2.convexHull(np.ascontiguousarray(target_points, dtype=np.float32))
    return float(cv2.contourArea(hull)) / roi_area


def inside_convex(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Which ``points`` (N x 2) lie inside (or on) the convex ``polygon`` (either winding): the frame
    keypoints a found copy of the target occupies, which cannot belong to another copy."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    corners = np.asarray(polygon, dtype=np.float64).reshape(-1, 2)
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    edges = np.roll(corners, -1, axis=0) - corners
    relative = points[:, None, :] - corners[None, :, :]
    cross = edges[None, :, 0] * relative[:, :, 1] - edges[None, :, 1] * relative[:, :, 0]
    return np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)


def overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two convex outlines (0 where they do not touch): how much two found
    copies of the target share, to tell a second copy from the same one found again."""
    a32 = np.ascontiguousarray(a, dtype=np.float32).reshape(-1, 2)
    b32 = np.ascontiguousarray(b, dtype=np.float32).reshape(-1, 2)
    inter, _ = cv2.intersectConvexConvex(a32, b32)
    union = cv2.contourArea(a32) + cv2.contourArea(b32) - inter
    return float(inter / union) if union > 0 else 0.0


def corner_error(found: np.ndarray, truth: np.ndarray) -> float:
    """The largest distance between corresponding corners, in pixels (for tests and benchmarks)."""
    found = np.asarray(found, dtype=np.float64).reshape(-1, 2)
    truth = np.asarray(truth, dtype=np.float64).reshape(-1, 2)
    return float(max(math.hypot(*(f - t)) for f, t in zip(found, truth, strict=True)))
