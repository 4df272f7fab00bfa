"""Debug views of a feature detector: keypoints on the frame, and the side-by-side view (the
current frame on the left, the target image on the right, lines between matched keypoints with inliers
distinguished from outliers, and the detected polygon)."""

from __future__ import annotations

import cv2
import numpy as np

from strictio.shown import drawable

from ..base import as_bgr
from .result import FeatureMatch
from .target import Target

INLIER = (0, 220, 0)
OUTLIER = (0, 0, 230)
KEYPOINT = (255, 160, 0)
FOUND = (0, 255, 255)
REJECTED = (0, 0, 255)
SELECTION = (255, 0, 255)


def _poly(canvas: np.ndarray, corners: np.ndarray, colour: tuple[int, int, int], thickness: int = 2) -> None:
    pts = np.round(np.asarray(corners, dtype=np.float64) * 16).astype(np.int32).reshape(-1, 1, 2)
    cv2.polylines(canvas, [pts], True, colour, thickness, cv2.LINE_AA, shift=4)


def _status_line(canvas: np.ndarray, match: FeatureMatch | None) -> None:
    if match is None:
        text, colour = "no frame processed", REJECTED
    elif len(match.instances) > 1:
        text = f"found {len(match.instances)} copies: " + "+".join(str(i.inlier_count) for i in match.instances)
        text, colour = text + " inliers", FOUND
    elif match.found:
        text = f"found: {len(match.matches)} matches, {match.inlier_count} inliers"
        colour = FOUND
    else:
        text, colour = f"not found: {match.reason}", REJECTED
    (width, height), baseline = cv2.getTextSize(drawable(text), cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1)
    cv2.rectangle(canvas, (2, 2), (10 + width, 8 + height + baseline), (0, 0, 0), -1)
    cv2.putText(canvas, drawable(text), (6, 4 + height), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv2.LINE_AA)


def _draw_quadrilateral(canvas: np.ndarray, match: FeatureMatch) -> None:
    """Every copy found (or the rejected outline, thin and red)."""
    if match.found:
        for instance in match.instances or ():
            _poly(canvas, instance.quadrilateral, FOUND, 2)
    elif match.quadrilateral is not None and np.all(np.isfinite(match.quadrilateral)):
        _poly(canvas, match.quadrilateral, REJECTED, 1)


def _match_sets(match: FeatureMatch) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(frame index, target index, inlier mask) per copy found, or of the one attempt."""
    if match.instances:
        return [(i.matches.frame_idx, i.matches.target_idx, i.inliers) for i in match.instances]
    inliers = match.inliers if len(match.inliers) == len(match.matches) else np.zeros(len(match.matches), bool)
    return [(match.matches.frame_idx, match.matches.target_idx, inliers)]


def keypoints_view(frame: np.ndarray, match: FeatureMatch | None) -> np.ndarray:
    """The frame with every keypoint found in it (small circles), matched ones larger, and the polygon."""
    canvas = as_bgr(frame).copy()
    if match is not None:
        for x, y in np.round(match.frame_points).astype(int):
            cv2.circle(canvas, (int(x), int(y)), 2, KEYPOINT, 1, cv2.LINE_AA)
        for frame_idx, _, inliers in _match_sets(match):
            for index, inlier in zip(frame_idx, inliers, strict=True):
                x, y = np.round(match.frame_points[index]).astype(int)
                cv2.circle(canvas, (int(x), int(y)), 4, INLIER if inlier else OUTLIER, 1, cv2.LINE_AA)
        _draw_quadrilateral(canvas, match)
    _status_line(canvas, match)
    return canvas


def side_by_side(frame: np.ndarray, target: Target | None, match: FeatureMatch | None) -> np.ndarray:
    """Frame left, target right, match lines (inliers green, outliers red, outliers drawn first so the
    inliers stay visible), the selection outlined on the target and the projected outline on the frame."""
    left = as_bgr(frame)
    if target is None:
        canvas = left.copy()
        _status_line(canvas, match)
        return canvas
    right = as_bgr(target.image)
    height = max(left.shape[0], right.shape[0])
    offset = left.shape[1]
    canvas = np.zeros((height, offset + right.shape[1], 3), dtype=np.uint8)
    canvas[: left.shape[0], :offset] = left
    canvas[: right.shape[0], offset:] = right
    _poly(canvas, target.corners() + np.float32([offset, 0]), SELECTION, 1)
    for x, y in np.round(target.points).astype(int):
        cv2.circle(canvas, (int(x) + offset, int(y)), 2, KEYPOINT, 1, cv2.LINE_AA)
    sets = _match_sets(match) if match is not None and len(match.matches) else []
    for draw_inliers in (False, True):
        colour = INLIER if draw_inliers else OUTLIER
        for frame_idx, target_idx, inliers in sets:
            chosen = inliers == draw_inliers
            frame_xy = match.frame_points[frame_idx[chosen]]
            target_xy = target.points[target_idx[chosen]] + np.float32([offset, 0])
            for (fx, fy), (tx, ty) in zip(frame_xy, target_xy, strict=True):
                cv2.line(canvas, (round(fx), round(fy)), (round(tx), round(ty)), colour, 1, cv2.LINE_AA)
    if match is not None:
        _draw_quadrilateral(canvas, match)
    _status_line(canvas, match)
    return canvas
