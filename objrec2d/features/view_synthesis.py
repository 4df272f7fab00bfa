"""Tilted views of the target, so that a poster seen 60 degrees off its normal is still matched (as in ASIFT).

Keypoint detectors and descriptors cope with rotation and scale, but not with the strong affine squash of an
oblique view: seen 60 degrees off its normal a flat target is compressed 2x across the viewing direction, and
ORB's patches, SIFT's gradients and AKAZE's bands no longer look like the target's. ASIFT (Morel and Yu, 2009)
answers by simulating those views: each *tilt* t compresses the image by 1/t along one axis (t = 1/cos of the
viewing angle), at several *longitudes* (directions of that axis). Here the views are made once, when the
target is computed; keypoints are detected on each, mapped back into the target's own coordinates and kept
with their descriptors in one set. A frame is matched against that union as before, so the cost per frame
grows only with the extra target keypoints (not with a matching pass per view, as full ASIFT does).

The sampling is ASIFT's: tilts t = sqrt(2)^k for k = 1..``view_tilts``, and with ``view_longitudes`` ``all``
longitudes 0 to 180 degrees in steps of 72/t degrees: ``view_tilts`` 1 adds 4 views (t = 1.41, viewing angles
up to 45 degrees), 2 adds 5 more at t = 2 (60 degrees), 9 in all, 3 adds 8 more at t = 2.83 (69 degrees).
``sideways`` keeps longitude 0 only, the target squashed along its width: how a camera at the target's height
sees it from the left or right, a robot's case; one view per tilt, so 2 tilts triple the target's keypoints
where ``all`` makes them ten times as many (and the matching time per frame with them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

#: Most tilt levels offered: t = 2.83 (69 degrees off the normal). Each level adds more views than the last, and
#: the matching time per frame grows with them (ASIFT goes on to t = 5.7, matching every view pair apart).
MAX_VIEW_TILTS = 3
#: ASIFT's longitude step at tilt t is this many degrees divided by t.
LONGITUDE_STEP_DEG = 72.0
#: Which longitudes are simulated: ASIFT's full half-turn, or only the squash along the target's width.
VIEW_LONGITUDES: tuple[str, ...] = ("all", "sideways")
#: ASIFT's anti-aliasing: before compressing by t, a Gaussian of sigma 0.8 * sqrt(t^2 - 1) along that axis.
ANTIALIAS_SIGMA = 0.8


@dataclass(frozen=True)
class TiltedView:
    """One simulated view: the affine map from the target image into it, and the view's tilt and longitude."""

    tilt: float
    longitude_deg: float
    affine: np.ndarray  # 2 x 3, target image -> view


def view_angles(view_tilts: int, longitudes: str = "all") -> list[tuple[float, float]]:
    """(tilt, longitude in degrees) of every simulated view for ``view_tilts`` tilt levels (ASIFT's sampling)."""
    if not 0 <= view_tilts <= MAX_VIEW_TILTS:
        raise ValueError(f"view_tilts: expected 0 to {MAX_VIEW_TILTS}, found {view_tilts!r}")
    if longitudes not in VIEW_LONGITUDES:
        raise ValueError(f"view_longitudes: expected one of {', '.join(VIEW_LONGITUDES)}, found {longitudes!r}")
    angles = []
    for k in range(1, view_tilts + 1):
        tilt = math.sqrt(2.0) ** k
        step = LONGITUDE_STEP_DEG / tilt
        count = math.ceil(180.0 / step - 1e-9) if longitudes == "all" else 1
        angles.extend((tilt, i * step) for i in range(count))
    return angles


def render_view(gray: np.ndarray, mask: np.ndarray, tilt: float, longitude_deg: float
                ) -> tuple[np.ndarray, np.ndarray, TiltedView]:
    """The picture and keypoint mask of one view: rotated by the longitude, blurred along x, squashed by the
    tilt along x; and the affine map from ``gray`` into it.

    The blur comes before the squash (ASIFT's anti-aliasing) so that fine texture does not alias into false
    corners; the mask is eroded by a pixel so no keypoint sits on the selection's edge."""
    height, width = gray.shape[:2]
    rotation = cv2.getRotationMatrix2D((0.0, 0.0), longitude_deg, 1.0)
    corners = np.array([[0, 0], [width - 1, 0], [width - 1, height - 1], [0, height - 1]], dtype=np.float64)
    moved = corners @ rotation[:, :2].T
    low, high = moved.min(axis=0), moved.max(axis=0)
    rotation[:, 2] = -low
    rotated_size = (math.ceil(high[0] - low[0]) + 1, math.ceil(high[1] - low[1]) + 1)
    rotated = cv2.warpAffine(gray, rotation, rotated_size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    rotated_mask = cv2.warpAffine(mask, rotation, rotated_size, flags=cv2.INTER_NEAREST, borderValue=0)
    sigma = ANTIALIAS_SIGMA * math.sqrt(tilt * tilt - 1.0)
    kernel = cv2.getGaussianKernel(2 * math.ceil(3 * sigma) + 1, sigma)
    blurred = cv2.sepFilter2D(rotated, -1, kernel, np.ones((1, 1)), borderType=cv2.BORDER_REPLICATE)
    squash = np.array([[1.0 / tilt, 0.0, 0.0], [0.0, 1.0, 0.0]])
    size = (math.ceil((rotated_size[0] - 1) / tilt) + 1, rotated_size[1])
    picture = cv2.warpAffine(blurred, squash, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    view_mask = cv2.warpAffine(rotated_mask, squash, size, flags=cv2.INTER_NEAREST, borderValue=0)
    view_mask = cv2.erode(view_mask, np.ones((3, 3), np.uint8))
    affine = squash[:, :2] @ rotation
    return picture, view_mask, TiltedView(tilt, longitude_deg, affine)


def to_target(keypoints: tuple[Any, ...], view: TiltedView) -> tuple[Any, ...]:
    """The keypoints of a view placed back in the target image: positions through the inverse affine map;
    size and angle are kept as detected (they only draw the debug view)."""
    if not keypoints:
        return ()
    inverse = cv2.invertAffineTransform(view.affine)
    points = cv2.KeyPoint_convert(keypoints).reshape(-1, 2).astype(np.float64)
    back = points @ inverse[:, :2].T + inverse[:, 2]
    return tuple(
        cv2.KeyPoint(float(x), float(y), kp.size, kp.angle, kp.response, kp.octave, kp.class_id)
        for (x, y), kp in zip(back, keypoints, strict=True)
    )


def tilted_features(extractor: Any, gray: np.ndarray, mask: np.ndarray, view_tilts: int, longitudes: str = "all"
                    ) -> tuple[tuple[Any, ...], list[np.ndarray]]:
    """Keypoints (in ``gray``'s coordinates, inside ``mask``) and descriptors of every simulated view."""
    keypoints: list[Any] = []
    descriptors: list[np.ndarray] = []
    for tilt, longitude in view_angles(view_tilts, longitudes):
        picture, view_mask, view = render_view(gray, mask, tilt, longitude)
        found, described = extractor.detectAndCompute(picture, view_mask)
        if described is None or not found:
            continue
        back = to_target(tuple(found), view)
        height, width = mask.shape[:2]
        inside = [
            i for i, kp in enumerate(back)
            if 0 <= kp.pt[0] < width and 0 <= kp.pt[1] < height and mask[int(kp.pt[1]), int(kp.pt[0])]
        ]
        keypoints.extend(back[i] for i in inside)
        descriptors.append(described[inside])
    return tuple(keypoints), descriptors


def turned_homography(size: tuple[int, int], angle_deg: float, distance: float, width_m: float = 0.8,
                      focal: float = 525.0, principal: tuple[float, float] = (320.0, 240.0)) -> np.ndarray:
    """Target pixel -> frame pixel for a flat target ``size`` (width, height) px printed ``width_m`` wide,
    ``distance`` m in front of a pinhole camera (``focal`` px, ``principal`` point) and turned ``angle_deg``
    about its vertical axis: how a camera at its height sees it from that far round to the side, the exact
    perspective view the simulated tilts approximate (the inspection lab's Xtion and poster by default)."""
    width, height = size
    a = math.radians(angle_deg)
    camera = np.array([[focal, 0.0, principal[0]], [0.0, focal, principal[1]], [0.0, 0.0, 1.0]])
    turn = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    metres = width_m / width
    to_plane = np.array([[metres, 0.0, -metres * width / 2], [0.0, metres, -metres * height / 2], [0.0, 0.0, 1.0]])
    matrix = camera @ np.column_stack([turn[:, 0], turn[:, 1], [0.0, 0.0, distance]]) @ to_plane
    return matrix / matrix[2, 2]
