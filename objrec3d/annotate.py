"""The ``--annotate`` picture for 3D: the cloud seen from the sensor, with each detected box drawn.

An organized cloud is drawn as the image it came from (its colours, or its depth as grey) and the pinhole
intrinsics are recovered from the points themselves, so boxes land exactly on the pixels they came from.
An unorganized cloud is splatted through a virtual 640 x 480 camera at the sensor. OpenCV draws; nothing
else in the 3D library needs it.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import cv2
import numpy as np

from strictio.shown import drawable

from .cloud import PointCloud, as_cloud
from .messages import DetectedObject3D

_EDGES = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
_DEFAULT = (525.0, 525.0, 319.5, 239.5)


def estimate_intrinsics(cloud: PointCloud) -> tuple[float, float, float, float]:
    """fx, fy, cx, cy of an organized cloud, by least squares on u = fx x/z + cx and v = fy y/z + cy."""
    valid = np.flatnonzero(cloud.valid_mask())
    valid = valid[cloud.points[valid, 2] > 0]
    if valid.size < 10:
        return _DEFAULT
    valid = valid[:: max(1, valid.size // 5000)]
    v, u = np.divmod(valid, cloud.width)
    p = cloud.points[valid].astype(np.float64)
    result = []
    for pixel, ratio in ((u, p[:, 0] / p[:, 2]), (v, p[:, 1] / p[:, 2])):
        a = np.stack([ratio, np.ones_like(ratio)], axis=1)
        (f, c), *_ = np.linalg.lstsq(a, pixel.astype(np.float64), rcond=None)
        result.append((f, c))
    (fx, cx), (fy, cy) = result
    if not (np.isfinite([fx, fy, cx, cy]).all() and fx > 0 and fy > 0):
        return _DEFAULT
    return float(fx), float(fy), float(cx), float(cy)


def render_cloud(cloud: PointCloud) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """A BGR picture of the cloud from the sensor and the intrinsics that map points onto it."""
    if cloud.is_organized:
        valid = cloud.valid_mask().reshape(cloud.height, cloud.width)
        if cloud.colors is not None:
            image = cloud.grid(cloud.colors)[..., ::-1].copy()
        else:
            image = _depth_grey(cloud.points[:, 2]).reshape(cloud.height, cloud.width, 3)
        image[~valid] = 0
        return np.ascontiguousarray(image), estimate_intrinsics(cloud)
    fx, fy, cx, cy = _DEFAULT
    image = np.zeros((480, 640, 3), dtype=np.uint8)
    points = cloud.points[cloud.valid_mask()]
    colors = cloud.colors[cloud.valid_mask()] if cloud.colors is not None else None
    front = points[:, 2] > 1e-6
    points = points[front]
    if points.shape[0]:
        u = np.round(fx * points[:, 0] / points[:, 2] + cx).astype(np.int64)
        v = np.round(fy * points[:, 1] / points[:, 2] + cy).astype(np.int64)
        inside = (u >= 0) & (u < 640) & (v >= 0) & (v < 480)
        order = np.argsort(-points[inside, 2])  # far first, near ones overwrite
        shade = (colors[front][inside][:, ::-1] if colors is not None
                 else _depth_grey(points[inside, 2]))
        image[v[inside][order], u[inside][order]] = shade[order]
    return image, _DEFAULT


def _depth_grey(z: np.ndarray) -> np.ndarray:
    finite = np.isfinite(z)
    grey = np.zeros(z.shape, dtype=np.uint8)
    if finite.any():
        lo, hi = np.percentile(z[finite], [1, 99])
        grey[finite] = np.clip(255 - (z[finite] - lo) / max(hi - lo, 1e-6) * 200, 30, 255).astype(np.uint8)
    return np.repeat(grey[:, None], 3, axis=1)


def draw_objects(image: np.ndarray, objects: Iterable[Any], intrinsics: tuple[float, float, float, float]
                 ) -> np.ndarray:
    """Draw each object's box (its 12 edges) and a label onto ``image`` (in place; also returned)."""
    fx, fy, cx, cy = intrinsics
    placed: list[tuple[int, int, int, int]] = []
    labels: list[tuple[str, tuple[int, int]]] = []
    for obj in objects:
        if not isinstance(obj, DetectedObject3D):
            obj = DetectedObject3D.from_dict(obj) if isinstance(obj, dict) else obj
        corners = obj.box.corners()
        if (corners[:, 2] <= 1e-6).any():
            continue  # behind the camera: nothing sensible to draw
        uv = np.stack([fx * corners[:, 0] / corners[:, 2] + cx, fy * corners[:, 1] / corners[:, 2] + cy], axis=1)
        pts = np.round(uv).astype(np.int32)
        for a, b in _EDGES:
            cv2.line(image, tuple(int(c) for c in pts[a]), tuple(int(c) for c in pts[b]), (0, 255, 0), 2, cv2.LINE_AA)
        top = pts[np.argmin(pts[:, 1])]
        labels.append((_label(obj), (int(top[0]), int(top[1]) - 8)))
    for text, anchor in labels:  # after every box, so that no box edge crosses a label
        _put_label(image, text, anchor, placed)
    return image


def _label(obj: DetectedObject3D) -> str:
    """Name, shape and size: the radius of a round shape, the extent of a plane."""
    label = obj.name
    if obj.shape:
        label += "" if obj.shape == obj.name else f" ({obj.shape})"
        if obj.shape == "plane":
            label += f" {obj.box.width:.2f}x{obj.box.height:.2f}m"
        else:
            label += f" r={obj.radius * 1000:.1f}mm"
    return label


_FONT, _SCALE = cv2.FONT_HERSHEY_SIMPLEX, 0.45


def _put_label(image: np.ndarray, text: str, anchor: tuple[int, int], placed: list[tuple[int, int, int, int]]
               ) -> None:
    """Write ``text`` centred over ``anchor`` on a dark strip, moved up (or down) until it overlaps no label
    already ``placed``: neighbouring objects' labels stay readable."""
    (w, h), base = cv2.getTextSize(drawable(text), _FONT, _SCALE, 1)
    height, width = image.shape[:2]
    x = int(np.clip(anchor[0] - w // 2, 2, max(2, width - w - 2)))
    y = max(anchor[1], h + 4)
    step = h + base + 4

    def overlaps(top: int) -> bool:
        box = (x - 2, top - h - 2, x + w + 2, top + base + 2)
        return any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in placed)

    for candidate in [y - k * step for k in range(8)] + [y + k * step for k in range(1, 8)]:
        if h + 2 <= candidate <= height - base - 2 and not overlaps(candidate):
            y = candidate
            break
    box = (x - 2, y - h - 2, x + w + 2, y + base + 2)
    image[max(box[1], 0):box[3], max(box[0], 0):box[2]] //= 3  # a darkened strip under the text
    cv2.putText(image, drawable(text), (x, y), _FONT, _SCALE, (0, 255, 255), 1, cv2.LINE_AA)
    placed.append(box)


def annotate(frame: Any, array: Any) -> np.ndarray:
    """The cloud of ``frame`` (a Frame or a cloud) as a BGR uint8 image with the boxes of ``array`` drawn."""
    data = getattr(frame, "data", frame)
    image, intrinsics = render_cloud(as_cloud(data))
    objects = getattr(array, "objects", array) or []
    return draw_objects(image, objects, intrinsics)
