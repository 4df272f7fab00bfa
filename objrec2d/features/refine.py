"""Homography refinement after the robust fit: a least-squares refit on all the inliers (geometric), then an
alignment of the target's pixels with the frame's (photometric).

A robust estimator (RANSAC, MAGSAC) keeps the model of its best minimal sample, refined at most on that sample's
consensus; with keypoints placed no better than a pixel (ORB's pyramid level k has pixels 1.2^k wide), the far
corners of the projected selection swing by pixels: before this module ORB was 2.3 px off on pasted copies of
box.png and 7.8 px on box_in_scene.png; the refit alone brings box_in_scene to 5 px, the alignment to 0.5 px.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .geometry import project

#: Rounds of refit-and-reselect after the robust fit; the inlier set settles in one or two.
REFINE_ROUNDS = 3


def refine_homography(
    target_points: np.ndarray, frame_points: np.ndarray, matrix: np.ndarray, inliers: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """The homography re-fitted to all its inliers on the reprojection error (``findHomography`` with method 0:
    a linear fit refined by OpenCV's Levenberg-Marquardt), the inliers re-selected with it among all matches,
    until they settle. A refit that loses inliers or fails is not taken.

    Weighing each match by its keypoints' sizes (coarse pyramid levels place keypoints less precisely) was
    tried: it moved the corners of pasted box.png copies by under 0.1 px and cost twice OpenCV's refit.
    """
    source = np.ascontiguousarray(target_points, dtype=np.float64).reshape(-1, 2)
    destination = np.ascontiguousarray(frame_points, dtype=np.float64).reshape(-1, 2)
    best, best_mask = matrix, inliers
    for _ in range(REFINE_ROUNDS):
        if int(best_mask.sum()) < 5:  # 4 points fit exactly: nothing to average
            break
        try:
            refined, _ = cv2.findHomography(source[best_mask], destination[best_mask], 0)
        except cv2.error:
            break
        if refined is None or not np.all(np.isfinite(refined)):
            break
        projected, w = project(refined, source)
        with np.errstate(invalid="ignore"):
            error = np.hypot(*(projected - destination).T)
        mask = (w > 0) & (error < threshold)
        if mask.sum() < best_mask.sum():
            break
        settled = np.array_equal(mask, best_mask)
        best, best_mask = refined, mask
        if settled:
            break
    return best, best_mask


#: Most template pixels the photometric alignment works on; a larger selection is aligned at reduced resolution.
PHOTOMETRIC_MAX_PIXELS = 40_000
#: Iterations, and the gain in correlation below which the alignment stops; it starts from the keypoint fit,
#: a pixel or two off (at 1e-3 it stopped 0.8 px short of a 1.8 px offset).
PHOTOMETRIC_ITERATIONS = 20
PHOTOMETRIC_EPSILON = 1e-4
#: Pixels of frame kept around the outline the keypoint fit projects: the alignment (which smooths and
#: differentiates all the frame it is given) sees only that window.
PHOTOMETRIC_MARGIN = 16
#: The lowest correlation an alignment may end at to be taken (a view of the target, not of something hiding it).
PHOTOMETRIC_MIN_CORRELATION = 0.6


def refine_photometric(
    target_gray: np.ndarray, roi: tuple[int, int, int, int], frame_gray: np.ndarray, matrix: np.ndarray,
    max_shift: float,
) -> tuple[np.ndarray | None, str]:
    """The homography that best aligns the selection's pixels with the frame's (OpenCV's enhanced correlation
    coefficient, ``findTransformECC`` with ``MOTION_HOMOGRAPHY``), started from ``matrix``; or None and why not.

    Keypoints are placed to a fraction of a pixel at best, a pixel or more on coarse pyramid levels; the
    correlation of all the selection's pixels places it to a tenth of a pixel on pasted copies of box.png
    (0.12-0.24 px where ORB's keypoints alone give 0.6-2.3 px). It is invariant to brightness and contrast
    changes, not to a part of the target being hidden or out of the frame: an alignment that fails, ends
    below PHOTOMETRIC_MIN_CORRELATION or moves a corner of the selection by more than ``max_shift`` pixels
    is not taken. The template is the selection at about the resolution it has in the frame (no more than
    PHOTOMETRIC_MAX_PIXELS), which is all the detail the frame can match and keeps the cost to a few ms.
    """
    x, y, width, height = roi
    corners = np.array([[x - 0.5, y - 0.5], [x + width - 0.5, y - 0.5], [x + width - 0.5, y + height - 0.5],
                        [x - 0.5, y + height - 0.5]])
    start, _ = project(matrix, corners)
    (ax, ay), (bx, by) = start[2] - start[0], start[3] - start[1]
    seen_area = 0.5 * abs(float(ax * by - ay * bx))  # half the cross product of the diagonals
    k = min(1.0, math.sqrt(seen_area / (width * height)), math.sqrt(PHOTOMETRIC_MAX_PIXELS / (width * height)))
    template = target_gray[y:y + height, x:x + width]
    if k < 1.0:
        template = cv2.resize(template, (max(8, round(width * k)), max(8, round(height * k))),
                              interpolation=cv2.INTER_AREA)
    kx, ky = template.shape[1] / width, template.shape[0] / height
    # Template pixel centre (i, j) lies at target image coordinates ((i + 0.5) / kx - 0.5 + x, ...).
    to_target = np.array([[1 / kx, 0.0, 0.5 / kx - 0.5 + x], [0.0, 1 / ky, 0.5 / ky - 0.5 + y], [0.0, 0.0, 1.0]])
    from_target = np.array([[kx, 0.0, -kx * to_target[0, 2]], [0.0, ky, -ky * to_target[1, 2]], [0.0, 0.0, 1.0]])
    margin = PHOTOMETRIC_MARGIN + max_shift
    frame_height, frame_width = frame_gray.shape[:2]
    x0, y0 = max(0, int(start[:, 0].min() - margin)), max(0, int(start[:, 1].min() - margin))
    x1 = min(frame_width, math.ceil(start[:, 0].max() + margin) + 1)
    y1 = min(frame_height, math.ceil(start[:, 1].max() + margin) + 1)
    if x1 - x0 < 8 or y1 - y0 < 8:
        return None, "the outline lies outside the frame"
    window = frame_gray[y0:y1, x0:x1]
    shift = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
    unshift = np.array([[1.0, 0.0, x0], [0.0, 1.0, y0], [0.0, 0.0, 1.0]])
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, PHOTOMETRIC_ITERATIONS, PHOTOMETRIC_EPSILON)
    try:
        correlation, warp = cv2.findTransformECC(
            template, window, (shift @ matrix @ to_target).astype(np.float32), cv2.MOTION_HOMOGRAPHY, criteria,
            None, 3,
        )
    except cv2.error:  # no convergence, or a singular step: the keypoint fit stands
        return None, "the photometric alignment did not converge"
    if not np.isfinite(correlation) or correlation < PHOTOMETRIC_MIN_CORRELATION:
        return None, f"the photometric alignment ends at correlation {correlation:.2f}"
    refined = unshift @ warp.astype(np.float64) @ from_target
    if not np.all(np.isfinite(refined)) or abs(refined[2, 2]) < 1e-12:
        return None, "the photometric alignment gave no finite homography"
    refined /= refined[2, 2]
    moved, w = project(refined, corners)
    if np.any(w <= 0):
        return None, "the photometric alignment folds the selection"
    shift = float(np.hypot(*(moved - start).T).max())
    if shift > max_shift:
        return None, f"the photometric alignment moves a corner {shift:.1f} px (more than {max_shift:g})"
    return refined, ""
