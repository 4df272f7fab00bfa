"""Homography refinement after the robust fit: a least-squares refit on all the inliers (geometric), then an
alignment of the target's pixels with the frame's (photometric).

A robust estimator (RANSAC, MAGSAC) keeps the model of its best minimal sample, refined at most on that sample's
consensus; with keypoints placed no better than a pixel (ORB's pyramid level k has pixels 1.2^k wide), the far
corners of the projected selection swing by pixels: before this module ORB was 2.3 px off on pasted copies of
box.png and 7.8 px on box_in_scene.png; the refit alone brings box_in_scene to 5 px, the alignment to 0.5 px.
The fit's inliers judge the alignment: it is taken where they agree with it about as well as with the fit, however
far it moves a corner they cannot reach (the lab poster 60-70 degrees off its normal: ORB 8-18 px -> 0.1-0.4 px),
and refused where it carries them away (pulled onto a copy of the target hiding part of it).
"""

from __future__ import annotations

import functools
import logging
import math

import cv2
import numpy as np

from .geometry import homogeneous_points, project_homogeneous

log = logging.getLogger(__name__)

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
    source, destination = _as_points(target_points), _as_points(frame_points)
    homogeneous = homogeneous_points(source)  # made once (in float64) for every round's reprojection
    best, best_mask = matrix, inliers
    best_count = np.count_nonzero(best_mask)
    for _ in range(REFINE_ROUNDS):
        if best_count < 5:  # 4 points fit exactly: nothing to average
            break
        try:
            refined, _ = cv2.findHomography(source[best_mask], destination[best_mask], 0)
        except cv2.error:
            break
        if refined is None or not np.isfinite(refined).all():
            break
        projected = homogeneous @ refined.T  # project_homogeneous's product and division; a match whose w
        w = projected[:, 2]  # is 0 (projected to infinity) is no inlier, so no w need be checked first
        if w.all():  # nothing divided by zero (the usual case): no need to silence NumPy, which costs more
            offset = projected[:, :2] / w[:, None] - destination
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                offset = projected[:, :2] / w[:, None] - destination
        error = np.hypot(offset[:, 0], offset[:, 1])
        mask = (w > 0) & (error < threshold)
        count = np.count_nonzero(mask)
        if count < best_count:
            break
        settled = count == best_count and not (mask != best_mask).any()
        best, best_mask, best_count = refined, mask, count
        if settled:
            break
    return best, best_mask


def _as_points(points: np.ndarray) -> np.ndarray:
    """N x 2 points as they are where float32 or float64 (``findHomography`` works in float32 whichever it is
    handed, and NumPy widens float32 exactly where they meet float64), else in float64: no copy per frame."""
    points = np.asarray(points)
    if points.dtype != np.float32 and points.dtype != np.float64:
        points = points.astype(np.float64)
    return points.reshape(-1, 2)


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
#: An alignment the keypoint inliers judge is taken only where it keeps PHOTOMETRIC_MIN_KEPT of them within the
#: reprojection threshold and raises their squared error by at most PHOTOMETRIC_MAX_KEYPOINT_COST times their
#: residual variance (taken as at least the floor's square, in px: keypoints placed exactly leave no noise to
#: measure by); one that moves a corner beyond ``max_shift`` must also raise the correlation by PHOTOMETRIC_MIN_GAIN.
#: The true homography of the lab poster seen 50-70 degrees off its normal costs up to 46 (keypoint errors are not
#: independent: 8 parameters would give about 8) and keeps 81-100 % within 3 px; alignments pulled onto a copy of
#: the poster hiding part of it (9-12 px off) keep 42-77 % or cost 60-129.
PHOTOMETRIC_MIN_GAIN = 0.01
#: Fewest inliers that judge an alignment (an 8-parameter fit needs a few more than 8 to leave a residual).
PHOTOMETRIC_MIN_JUDGES = 10
PHOTOMETRIC_MIN_KEPT = 0.8
PHOTOMETRIC_MAX_KEYPOINT_COST = 50.0
PHOTOMETRIC_NOISE_FLOOR = 0.5


def refine_photometric(
    target_gray: np.ndarray, roi: tuple[int, int, int, int], frame_gray: np.ndarray, matrix: np.ndarray,
    max_shift: float, inlier_pairs: tuple[np.ndarray, np.ndarray] | None = None, threshold: float | None = None,
) -> tuple[np.ndarray | None, str]:
    """The homography that best aligns the selection's pixels with the frame's (OpenCV's enhanced correlation
    coefficient, ``findTransformECC`` with ``MOTION_HOMOGRAPHY``), started from ``matrix``; or None and why not.

    Keypoints are placed to a fraction of a pixel at best, a pixel or more on coarse pyramid levels; the
    correlation of all the selection's pixels places it to a tenth of a pixel on pasted copies of box.png
    (0.12-0.24 px where ORB's keypoints alone give 0.6-2.3 px). It is invariant to brightness and contrast
    changes, not to a part of the target being hidden or out of the frame: an alignment that fails or ends
    below PHOTOMETRIC_MIN_CORRELATION is not taken. ``inlier_pairs`` (the target and frame positions of the
    keypoint fit's inliers, selected within ``threshold`` px) judge any move of a corner beyond ``threshold``:
    an alignment they disagree with (see ``_keypoint_disagreement``) is not taken. A move of a corner by more
    than ``max_shift`` pixels is taken only where they judge it (at least PHOTOMETRIC_MIN_JUDGES of them) and the
    correlation rises: a far corner of a target seen 60 degrees off its normal lies well beyond its inliers, and
    ORB's fit leaves it 8 px off, which only the pixels can correct. The template is the selection at about the
    resolution it has in the frame (no more than PHOTOMETRIC_MAX_PIXELS), which is all the detail the frame can
    match and keeps the cost to a few ms.
    """
    refined, _, why = align_photometric(target_gray, roi, frame_gray, matrix, max_shift, inlier_pairs, threshold)
    return refined, why


def align_photometric(
    target_gray: np.ndarray, roi: tuple[int, int, int, int], frame_gray: np.ndarray, matrix: np.ndarray,
    max_shift: float, inlier_pairs: tuple[np.ndarray, np.ndarray] | None = None, threshold: float | None = None,
    start: np.ndarray | None = None,
) -> tuple[np.ndarray | None, tuple[np.ndarray, np.ndarray] | None, str]:
    """``refine_photometric`` for a detector that has projected the selection's outline already and checks the
    refined one next: ``start`` is the outline ``matrix`` gives (``project(matrix, rect_corners(roi))[0]``;
    projected here where None), and the answer carries the refined homography's outline (its points and their
    w) besides the homography and why not. The same computation as ``refine_photometric``, minus two projections."""
    x, y, width, height = roi
    corners = _selection_corners(x, y, width, height)
    if start is None:
        start, _ = project_homogeneous(matrix, corners)
    # Plain floats for the window's arithmetic (the same as NumPy's float64, without a call per number).
    (sx0, sy0), (sx1, sy1), (sx2, sy2), (sx3, sy3) = start.tolist()
    ax, ay, bx, by = sx2 - sx0, sy2 - sy0, sx3 - sx1, sy3 - sy1
    seen_area = 0.5 * abs(ax * by - ay * bx)  # half the cross product of the diagonals
    k = min(1.0, math.sqrt(seen_area / (width * height)), math.sqrt(PHOTOMETRIC_MAX_PIXELS / (width * height)))
    template = target_gray[y:y + height, x:x + width]
    if k < 1.0:
        template = cv2.resize(template, (max(8, round(width * k)), max(8, round(height * k))),
                              interpolation=cv2.INTER_AREA)
    kx, ky = template.shape[1] / width, template.shape[0] / height
    # Template pixel centre (i, j) lies at target image coordinates ((i + 0.5) / kx - 0.5 + x, ...).
    tx, ty = 0.5 / kx - 0.5 + x, 0.5 / ky - 0.5 + y
    to_target = np.array([[1 / kx, 0.0, tx], [0.0, 1 / ky, ty], [0.0, 0.0, 1.0]])
    from_target = np.array([[kx, 0.0, -kx * tx], [0.0, ky, -ky * ty], [0.0, 0.0, 1.0]])
    margin = PHOTOMETRIC_MARGIN + max_shift
    frame_height, frame_width = frame_gray.shape[:2]
    x0, y0 = max(0, int(min(sx0, sx1, sx2, sx3) - margin)), max(0, int(min(sy0, sy1, sy2, sy3) - margin))
    x1 = min(frame_width, math.ceil(max(sx0, sx1, sx2, sx3) + margin) + 1)
    y1 = min(frame_height, math.ceil(max(sy0, sy1, sy2, sy3) + margin) + 1)
    if x1 - x0 < 8 or y1 - y0 < 8:
        return None, None, "the outline lies outside the frame"
    window = frame_gray[y0:y1, x0:x1]
    shift_to_window = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
    unshift = np.array([[1.0, 0.0, x0], [0.0, 1.0, y0], [0.0, 0.0, 1.0]])
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, PHOTOMETRIC_ITERATIONS, PHOTOMETRIC_EPSILON)
    try:  # the start is made here: findTransformECC writes its answer into the matrix it is given
        correlation, warp = cv2.findTransformECC(
            template, window, (shift_to_window @ matrix @ to_target).astype(np.float32), cv2.MOTION_HOMOGRAPHY,
            criteria, None, 3,
        )
    except cv2.error:  # no convergence, or a singular step: the keypoint fit stands
        return None, None, "the photometric alignment did not converge"
    if not math.isfinite(correlation) or correlation < PHOTOMETRIC_MIN_CORRELATION:
        return None, None, f"the photometric alignment ends at correlation {correlation:.2f}"
    refined = unshift @ warp.astype(np.float64) @ from_target
    if not np.isfinite(refined).all() or abs(refined[2, 2]) < 1e-12:
        return None, None, "the photometric alignment gave no finite homography"
    refined /= refined[2, 2]
    moved = corners @ refined.T  # project_homogeneous, with no w to check: any w <= 0 is refused before dividing
    w = moved[:, 2]
    if (w <= 0).any():
        return None, None, "the photometric alignment folds the selection"
    moved = moved[:, :2] / w[:, None]
    offset = moved - start
    shift = float(np.hypot(offset[:, 0], offset[:, 1]).max())
    if inlier_pairs is not None and len(inlier_pairs[0]) < PHOTOMETRIC_MIN_JUDGES:
        inlier_pairs = None  # too few to judge by
    # A move within the reprojection threshold stays inside the band the keypoints themselves are placed in.
    if inlier_pairs is not None and threshold is not None and shift > threshold:
        disagreement = _keypoint_disagreement(matrix, refined, inlier_pairs, threshold)
        if disagreement is not None:
            return None, None, f"the photometric alignment moves a corner {shift:.1f} px, and {disagreement}"
    if shift > max_shift:
        refused = f"the photometric alignment moves a corner {shift:.1f} px (more than {max_shift:g})"
        if inlier_pairs is None or threshold is None:
            return None, None, f"{refused}, with fewer than {PHOTOMETRIC_MIN_JUDGES} keypoint inliers to judge it by"
        start_warp = (shift_to_window @ matrix @ to_target).astype(np.float32)
        gain = _correlation(template, window, warp) - _correlation(template, window, start_warp)
        if gain < PHOTOMETRIC_MIN_GAIN:
            return None, None, f"{refused}, and the correlation rises only {gain:.3f}"
        log.debug("photometric correction of %.1f px taken: correlation +%.3f, the keypoints agree", shift, gain)
    return refined, (moved, w), ""


@functools.lru_cache(maxsize=16)
def _selection_corners(x: int, y: int, width: int, height: int) -> np.ndarray:
    """The outline of the selection's pixels (``rect_corners``) as 4 x 3 rows (x, y, 1), made once per selection
    (read-only: every frame shares it)."""
    corners = np.array([[x - 0.5, y - 0.5, 1.0], [x + width - 0.5, y - 0.5, 1.0],
                        [x + width - 0.5, y + height - 0.5, 1.0], [x - 0.5, y + height - 0.5, 1.0]])
    corners.flags.writeable = False
    return corners


def _correlation(template: np.ndarray, window: np.ndarray, warp: np.ndarray) -> float:
    """The correlation coefficient of ``template`` with ``window`` seen through ``warp`` (template -> window), on
    the template pixels the warp finds inside the window: the measure the alignment maximises."""
    size = (template.shape[1], template.shape[0])
    seen = cv2.warpPerspective(window, warp, size, flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
    inside = cv2.warpPerspective(np.full(window.shape[:2], 255, np.uint8), warp, size,
                                 flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP)
    value = float(cv2.computeECC(template, seen, inside))
    return value if math.isfinite(value) else -1.0


def _keypoint_disagreement(
    fitted: np.ndarray, refined: np.ndarray, inlier_pairs: tuple[np.ndarray, np.ndarray], threshold: float
) -> str | None:
    """None where the inlier keypoints allow ``refined`` about as well as the homography ``fitted`` to them,
    else how they disagree.

    The least-squares fit is the homography its inliers agree with best; how much worse another one does, in
    units of the inliers' noise (the rise of their squared error over the fit's residual variance), measures how
    far it lies from the fit where the keypoints can tell (a Mahalanobis distance on the fit's 8 parameters): a
    corner extrapolated beyond the inliers moves far at little cost, a homography a period off on a repeated
    pattern, or pulled by something hiding the target, carries the inliers away with it."""
    source = np.asarray(inlier_pairs[0], dtype=np.float64).reshape(-1, 1, 2)
    destination = np.asarray(inlier_pairs[1], dtype=np.float64).reshape(-1, 2)
    count = len(source)
    # Squared reprojection errors; OpenCV's transform (a point at infinity lands on the origin: far from any
    # keypoint) costs a tenth of the NumPy arithmetic.
    before = np.square(cv2.perspectiveTransform(source, fitted).reshape(-1, 2) - destination).sum(axis=1)
    after = np.square(cv2.perspectiveTransform(source, refined).reshape(-1, 2) - destination).sum(axis=1)
    kept = np.count_nonzero(after < threshold * threshold) / count
    if kept < PHOTOMETRIC_MIN_KEPT:
        return f"keeps only {kept:.0%} of the keypoint inliers within {threshold:g} px"
    fit_error, error = float(before.sum()), float(after.sum())
    cost = (error - fit_error) * (count - 8) / max(fit_error, count * PHOTOMETRIC_NOISE_FLOOR**2)
    if not cost <= PHOTOMETRIC_MAX_KEYPOINT_COST:  # NaN included
        return (f"the keypoint inliers' RMS error grows from {math.sqrt(fit_error / count):.2f} to "
                f"{math.sqrt(error / count):.2f} px ({cost:.0f} noise variances, more than "
                f"{PHOTOMETRIC_MAX_KEYPOINT_COST:g})")
    return None
