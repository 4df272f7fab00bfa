"""The target: the stored image of a selected object, where the selection lies in it, and the keypoints
and descriptors computed from it with one feature configuration.

Only the image, the rectangles and the configuration are saved; keypoints are recomputed on load (they
are cheap to recompute and depend on the OpenCV build). The image is kept with a margin of context
around the selection so that keypoints near its edges see whole patches, while a mask keeps every
keypoint inside the selection.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from objrec_core import Rect
from strictio import InputError

from ..base import as_gray
from ..sources import decode_image
from .geometry import homogeneous_points, rect_corners
from .types import FeatureConfig, create_feature2d, descriptor_norm
from .view_synthesis import tilted_features

log = logging.getLogger(__name__)

#: Pixels of context kept around a selection (clipped at the frame's edges).
TARGET_MARGIN = 32
#: The smallest selection side worth computing features on.
MIN_SELECTION_SIDE = 8

_STATE_KEYS = ("features", "rect", "roi", "keypoints", "opencv", "image_encoding", "image")


class TargetError(ValueError):
    """A target that cannot be made or loaded; the message says why."""


@dataclass(frozen=True, eq=False)
class Target:
    """Immutable, so a worker thread holding one keeps a consistent target while the GUI replaces it."""

    image: np.ndarray  # the stored picture (BGR or grey), the selection plus margin
    roi: Rect  # the selection inside ``image``
    rect: Rect  # the selection in the frame it was made on
    config: FeatureConfig
    keypoints: tuple[Any, ...]  # cv2.KeyPoint, in ``image`` coordinates
    points: np.ndarray  # N x 2 float32, the keypoints' positions
    descriptors: np.ndarray
    norm: int

    def __len__(self) -> int:
        return len(self.keypoints)

    @functools.cached_property
    def gray(self) -> np.ndarray:
        """The stored picture in grey, made once: what the photometric refinement aligns with each frame."""
        return as_gray(self.image)

    def corners(self) -> np.ndarray:
        """The selection's outline in ``image`` coordinates (4 x 2): what the homography projects."""
        return rect_corners(self.roi)

    @functools.cached_property
    def corners_homogeneous(self) -> np.ndarray:
        """``corners()`` as 4 x 3 rows (x, y, 1), made once: what ``project_homogeneous`` takes every frame
        (read-only, as every frame shares it)."""
        corners = homogeneous_points(self.corners())
        corners.flags.writeable = False
        return corners

    def with_config(self, config: FeatureConfig) -> Target:
        """The same image and selection, with keypoints recomputed for another configuration."""
        return compute_target(self.image, self.roi, self.rect, config)


def clip_rect(rect: Rect, shape: tuple[int, ...]) -> Rect | None:
    """The part of ``rect`` inside an image of ``shape``; None where nothing is left."""
    height, width = shape[:2]
    x0, y0 = max(rect.x, 0), max(rect.y, 0)
    x1, y1 = min(rect.x + rect.width, width), min(rect.y + rect.height, height)
    if x1 <= x0 or y1 <= y0:
        return None
    return Rect(x0, y0, x1 - x0, y1 - y0)


def compute_features(extractor: Any, gray: np.ndarray, mask: np.ndarray | None = None) -> tuple[tuple, np.ndarray]:
    """Keypoints and descriptors; an empty descriptor array (never None) where nothing was found."""
    keypoints, descriptors = extractor.detectAndCompute(gray, mask)
    if descriptors is None or len(keypoints) == 0:
        return (), np.empty((0, 0), dtype=np.uint8)
    return tuple(keypoints), descriptors


def _with_context(gray: np.ndarray, roi: Rect) -> tuple[np.ndarray, tuple[int, int]]:
    """The image extended, by repeating its edge pixels, to TARGET_MARGIN px of context on every side of
    the selection, and the offset of the original in it.

    ORB and BRISK keep keypoints a patch's width (31 px for ORB, at every pyramid level) away from the
    image's edge. A selection without context around it (an image selected whole, as box.png, or one at
    the frame's edge) would lose a band of keypoints along each side that way: on box.png the inliers
    then spanned 12 % of the box. The stored image stays as selected; only keypoint detection sees this.
    """
    height, width = gray.shape[:2]
    top = max(TARGET_MARGIN - roi.y, 0)
    left = max(TARGET_MARGIN - roi.x, 0)
    bottom = max(roi.y + roi.height + TARGET_MARGIN - height, 0)
    right = max(roi.x + roi.width + TARGET_MARGIN - width, 0)
    if not (top or left or bottom or right):
        return gray, (0, 0)
    return cv2.copyMakeBorder(gray, top, bottom, left, right, cv2.BORDER_REPLICATE), (left, top)


def _with_tilted_views(extractor: Any, gray: np.ndarray, mask: np.ndarray, config: FeatureConfig,
                       keypoints: tuple, descriptors: np.ndarray) -> tuple[tuple, np.ndarray]:
    """The target's own keypoints followed by those of its simulated oblique views (one descriptor set)."""
    extra, described = tilted_features(extractor, gray, mask, config.view_tilts, config.view_longitudes)
    if not extra:
        return keypoints, descriptors
    parts = [descriptors, *described] if len(keypoints) else described
    return keypoints + extra, np.vstack(parts)


def compute_target(image: np.ndarray, roi: Rect, rect: Rect, config: FeatureConfig) -> Target:
    """Keypoints and descriptors of the selection ``roi`` of ``image``."""
    if clip_rect(roi, image.shape) != roi:
        raise TargetError(f"the selection {roi} does not lie inside the {image.shape[1]}x{image.shape[0]} image")
    gray, (dx, dy) = _with_context(as_gray(image), roi)
    mask = np.zeros(gray.shape, dtype=np.uint8)
    mask[roi.y + dy : roi.y + dy + roi.height, roi.x + dx : roi.x + dx + roi.width] = 255
    extractor = create_feature2d(config)
    keypoints, descriptors = compute_features(extractor, gray, mask)
    if config.view_tilts:
        keypoints, descriptors = _with_tilted_views(extractor, gray, mask, config, keypoints, descriptors)
    if dx or dy:
        keypoints = tuple(
            cv2.KeyPoint(kp.pt[0] - dx, kp.pt[1] - dy, kp.size, kp.angle, kp.response, kp.octave, kp.class_id)
            for kp in keypoints
        )
    points = np.array([kp.pt for kp in keypoints], dtype=np.float32).reshape(-1, 2)
    return Target(image, roi, rect, config, keypoints, points, descriptors, descriptor_norm(extractor, descriptors))


def target_from_selection(frame: np.ndarray, rect: Rect, config: FeatureConfig) -> Target:
    """Crop the selection (plus margin) out of the frame, so the stored image stays small."""
    clipped = clip_rect(rect, frame.shape)
    if clipped is None:
        raise TargetError(f"the selection {rect} lies outside the {frame.shape[1]}x{frame.shape[0]} frame")
    if clipped.width < MIN_SELECTION_SIDE or clipped.height < MIN_SELECTION_SIDE:
        raise TargetError(
            f"the selection is {clipped.width}x{clipped.height} px; select at least "
            f"{MIN_SELECTION_SIDE}x{MIN_SELECTION_SIDE} px"
        )
    height, width = frame.shape[:2]
    x0, y0 = max(clipped.x - TARGET_MARGIN, 0), max(clipped.y - TARGET_MARGIN, 0)
    x1 = min(clipped.x + clipped.width + TARGET_MARGIN, width)
    y1 = min(clipped.y + clipped.height + TARGET_MARGIN, height)
    image = np.ascontiguousarray(frame[y0:y1, x0:x1]).copy()
    roi = Rect(clipped.x - x0, clipped.y - y0, clipped.width, clipped.height)
    return compute_target(image, roi, clipped, config)


# -- the parameter file ------------------------------------------------------------------------------------
def _rect_to_dict(rect: Rect) -> dict[str, int]:
    return {"x": rect.x, "y": rect.y, "width": rect.width, "height": rect.height}


def _rect_from_dict(value: Any, key: str) -> Rect:
    if not isinstance(value, Mapping) or set(value) != {"x", "y", "width", "height"}:
        raise TargetError(f"target.{key}: expected a mapping with x, y, width and height, found {value!r}")
    for name in ("x", "y", "width", "height"):
        if isinstance(value[name], bool) or not isinstance(value[name], int):
            raise TargetError(f"target.{key}.{name}: expected a whole number, found {value[name]!r}")
    try:
        return Rect(value["x"], value["y"], value["width"], value["height"])
    except ValueError as exc:
        raise TargetError(f"target.{key}: {exc}") from None


def target_to_state(target: Target) -> dict[str, Any]:
    """YAML-safe: the configuration, the rectangles, and the image as PNG bytes (written as !!binary)."""
    ok, png = cv2.imencode(".png", target.image)
    if not ok:  # pragma: no cover - PNG encodes any uint8 image
        raise TargetError("the target image cannot be encoded as PNG")
    return {
        "features": target.config.to_dict(),
        "rect": _rect_to_dict(target.rect),
        "roi": _rect_to_dict(target.roi),
        "keypoints": len(target),
        "opencv": cv2.__version__,
        "image_encoding": "png",
        "image": png.tobytes(),
    }


def _decode_png(data: bytes) -> np.ndarray:
    """The embedded PNG, its size checked from its header first: a parameter file of a few kilobytes may
    claim a 20000x20000 target, which is refused before anything is allocated."""
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        raise TargetError("target.image: not a readable PNG image (it does not start with the PNG signature)")
    try:
        image = decode_image(data, "target.image", cv2.IMREAD_UNCHANGED)
    except InputError as exc:
        raise TargetError(f"target.image: {exc.message}") from None
    if image.dtype != np.uint8 or image.ndim not in (2, 3):
        raise TargetError("target.image: not a readable 8-bit PNG image")
    return image


def target_from_state(state: Any, config: FeatureConfig) -> Target:
    """Decode and check a saved target, then recompute its keypoints with ``config``.

    The saved configuration must equal ``config``: a target computed with SIFT is never matched by a
    detector set to ORB, nor the other way round.
    """
    if not isinstance(state, Mapping):
        raise TargetError(f"target: expected a mapping, found {type(state).__name__}")
    unknown = sorted(set(map(str, state)) - set(_STATE_KEYS))
    if unknown:
        raise TargetError(f"target.{unknown[0]}: unknown key (allowed: {', '.join(_STATE_KEYS)})")
    for key in ("features", "rect", "roi", "image"):
        if key not in state:
            raise TargetError(f"target.{key}: missing")
    saved = state["features"]
    if not isinstance(saved, Mapping) or "type" not in saved:
        raise TargetError(f"target.features: expected the feature configuration with its type, found {saved!r}")
    if dict(saved) != config.to_dict():
        saved_text = ", ".join(f"{k}={v}" for k, v in saved.items() if k != "type")
        raise TargetError(
            f"target.features: the target was computed with {saved.get('type')} ({saved_text}), but the "
            f"parameters select {config.describe()}; set the parameters back to the target's configuration "
            "or select the target again"
        )
    encoding = state.get("image_encoding", "png")
    if encoding != "png":
        raise TargetError(f"target.image_encoding: only png is supported, found {encoding!r}")
    data = state["image"]
    if not isinstance(data, bytes | bytearray):
        raise TargetError(f"target.image: expected PNG bytes (!!binary), found {type(data).__name__}")
    image = _decode_png(bytes(data))
    roi = _rect_from_dict(state["roi"], "roi")
    rect = _rect_from_dict(state["rect"], "rect")
    if clip_rect(roi, image.shape) != roi:
        raise TargetError(f"target.roi: {roi} does not lie inside the {image.shape[1]}x{image.shape[0]} image")
    if (roi.width, roi.height) != (rect.width, rect.height):
        raise TargetError(f"target.roi: size {roi.width}x{roi.height} differs from rect's {rect.width}x{rect.height}")
    target = compute_target(image, roi, rect, config)
    saved_count = state.get("keypoints")
    if isinstance(saved_count, int) and saved_count != len(target):
        log.info(
            "target recomputed with %d keypoints where %d were saved (OpenCV %s, saved with %s)",
            len(target), saved_count, cv2.__version__, state.get("opencv", "?"),
        )
    return target
