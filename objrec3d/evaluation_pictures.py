"""The pictures of a 3D evaluation: error histograms, the shape-type confusion matrix and the worst frames
(the cloud from the sensor, truth shapes in green, detections in red). OpenCV draws, as for ``--annotate``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from strictio import write_atomically
from strictio.shown import drawable

from .annotate import render_cloud
from .cloud import as_cloud
from .messages import DetectedObject3D
from .truth import TruthShape, as_truth_shape

if TYPE_CHECKING:  # pragma: no cover
    from .evaluation import ShapeEvaluation

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_EDGES = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
TRUTH_COLOUR, DETECTION_COLOUR = (60, 220, 60), (60, 60, 255)


def save_png(path: Path, image: np.ndarray) -> Path:
    ok, data = cv2.imencode(".png", image)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 picture
        raise ValueError(f"{path}: the picture could not be encoded")
    write_atomically(path, data.tobytes())
    return path


def histogram(values: list[float], title: str, unit: str, scale: float = 1.0, size: tuple[int, int] = (420, 300),
              signed: bool = False) -> np.ndarray:
    """One histogram panel: 20 bins over the values' range (with 0). Unsigned errors get their median (blue)
    and 90th percentile (red) marked; signed ones (a bias shows) their median and the zero line (grey)."""
    w, h = size
    panel = np.full((h, w, 3), 255, np.uint8)
    cv2.putText(panel, drawable(title), (10, 20), _FONT, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    left, right, top, bottom = 45, w - 15, 35, h - 40
    cv2.line(panel, (left, bottom), (right, bottom), (0, 0, 0), 1)
    cv2.line(panel, (left, top), (left, bottom), (0, 0, 0), 1)
    if not values:
        cv2.putText(panel, "no true positive", (left + 20, (top + bottom) // 2), _FONT, 0.5, (90, 90, 90), 1,
                    cv2.LINE_AA)
        return panel
    v = np.asarray(values, dtype=float) * scale
    lo, hi = float(min(v.min(), 0.0)), float(max(v.max(), 0.0))
    if hi - lo < 1e-9:
        hi = lo + 1.0
    counts, edges = np.histogram(v, bins=20, range=(lo, hi))
    peak = max(int(counts.max()), 1)

    def x_of(value: float) -> int:
        return round(left + (value - lo) / (hi - lo) * (right - left))

    for n, a, b in zip(counts, edges[:-1], edges[1:], strict=True):
        if n:
            y = round(bottom - n / peak * (bottom - top))
            cv2.rectangle(panel, (x_of(a) + 1, y), (x_of(b) - 1, bottom - 1), (160, 120, 60), -1)
    marks = [(0.0, (150, 150, 150), "0"), (np.median(v), (200, 80, 0), "median")] if signed else \
        [(np.median(v), (200, 80, 0), "median"), (np.percentile(v, 90), (0, 0, 220), "p90")]
    for value, colour, name in marks:
        x = x_of(float(value))
        cv2.line(panel, (x, top), (x, bottom), colour, 1)
        if name == "0":
            continue  # the zero line: the axis says where 0 is
        cv2.putText(panel, drawable(f"{name} {value:.3g}"),
                    (min(x + 3, right - 90), top + (12 if name == "median" else 28)),
                    _FONT, 0.4, colour, 1, cv2.LINE_AA)
    for value in (lo, 0.5 * (lo + hi), hi):
        cv2.putText(panel, drawable(f"{value:.3g}"), (x_of(value) - 12, bottom + 15), _FONT, 0.4, (0, 0, 0), 1,
                    cv2.LINE_AA)
    cv2.putText(panel, drawable(unit), (right - 60, bottom + 32), _FONT, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(panel, drawable(str(peak)), (5, top + 5), _FONT, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(panel, drawable(f"n={v.size}"), (left + 5, bottom + 32), _FONT, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    return panel


def error_histograms(evaluation: ShapeEvaluation) -> np.ndarray:
    errors = evaluation.all.errors
    return np.hstack([histogram(errors["centre_error"], "centre error (all names)", "mm", 1000.0),
                      histogram(errors["radius_error"], "radius error, detected - true", "mm", 1000.0, signed=True),
                      histogram(errors["axis_error"], "cylinder axis error", "degrees")])


def confusion_picture(evaluation: ShapeEvaluation) -> np.ndarray:
    """The confusion matrix as a table: truth rows, detected columns, cells shaded by their share of the row."""
    from .evaluation import CONFUSION_COLUMNS, CONFUSION_ROWS

    cw, ch, head = 90, 40, 90
    image = np.full((head + ch * len(CONFUSION_ROWS) + 10, head + cw * len(CONFUSION_COLUMNS) + 10, 3), 255,
                    np.uint8)
    cv2.putText(image, "truth \\ detected", (5, 20), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    for j, name in enumerate(CONFUSION_COLUMNS):
        cv2.putText(image, drawable(name), (head + j * cw + 8, head - 15), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    for i, name in enumerate(CONFUSION_ROWS):
        y = head + i * ch
        cv2.putText(image, drawable(name), (5, y + 25), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
        total = max(int(evaluation.confusion[i].sum()), 1)
        for j in range(len(CONFUSION_COLUMNS)):
            n = int(evaluation.confusion[i, j])
            share = n / total
            right = CONFUSION_ROWS[i] == CONFUSION_COLUMNS[j]
            colour = (255 - int(150 * share), 255 - int(60 * share), 255 - int(150 * share)) if right else \
                (255 - int(150 * share), 255 - int(150 * share), 255)
            x = head + j * cw
            cv2.rectangle(image, (x, y), (x + cw - 2, y + ch - 2), colour, -1)
            cv2.rectangle(image, (x, y), (x + cw - 2, y + ch - 2), (180, 180, 180), 1)
            cv2.putText(image, drawable(str(n)), (x + 10, y + 26), _FONT, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
    return image


def truth_corners(shape: TruthShape) -> np.ndarray:
    """The 8 corners of the box around a truth shape (a cylinder's box: local y along its axis)."""
    centre = np.asarray(shape.centre, dtype=float)
    if shape.shape == "box" and shape.size is not None:
        half, rotation = 0.5 * np.asarray(shape.size, dtype=float), shape.rotation()
    elif shape.shape == "cylinder" and shape.axis is not None:
        y = np.asarray(shape.axis, dtype=float)
        x = np.cross(y, [0.0, 0.0, 1.0] if abs(y[2]) < 0.9 else [1.0, 0.0, 0.0])
        x /= np.linalg.norm(x)
        rotation = np.stack([x, y, np.cross(x, y)], axis=1)
        half = np.array([shape.radius, 0.5 * shape.height, shape.radius])
    else:
        half, rotation = np.full(3, shape.radius), np.eye(3)
    return (_SIGNS * half) @ rotation.T + centre


def _draw_box(image: np.ndarray, corners: np.ndarray, intrinsics: tuple[float, float, float, float],
              colour: tuple[int, int, int], label: str, below: bool) -> None:
    if not np.isfinite(corners).all() or (corners[:, 2] <= 1e-6).any():
        return
    fx, fy, cx, cy = intrinsics
    uv = np.stack([fx * corners[:, 0] / corners[:, 2] + cx, fy * corners[:, 1] / corners[:, 2] + cy], axis=1)
    pts = np.round(uv).astype(np.int32)
    for a, b in _EDGES:
        cv2.line(image, (int(pts[a][0]), int(pts[a][1])), (int(pts[b][0]), int(pts[b][1])), colour, 2, cv2.LINE_AA)
    anchor = pts[np.argmax(pts[:, 1])] + (0, 16) if below else pts[np.argmin(pts[:, 1])] - (0, 6)
    cv2.putText(image, drawable(label), (int(anchor[0]) - 30, int(anchor[1])), _FONT, 0.45, colour, 1, cv2.LINE_AA)


def worst_frame_picture(frame: object, truths: list[TruthShape], detections: list[DetectedObject3D],
                        caption: str) -> np.ndarray:
    image, intrinsics = render_cloud(as_cloud(getattr(frame, "data", frame)))
    for shape in truths:
        _draw_box(image, truth_corners(shape), intrinsics, TRUTH_COLOUR, f"{shape.name} (truth)", below=True)
    for obj in detections:
        _draw_box(image, obj.box.corners(), intrinsics, DETECTION_COLOUR, obj.name, below=False)
    cv2.rectangle(image, (0, 0), (image.shape[1], 24), (0, 0, 0), -1)
    cv2.putText(image, drawable(caption), (6, 17), _FONT, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
    return image


def write_pictures(evaluation: ShapeEvaluation, folder: Path) -> list[Path]:
    """3d-errors.png, 3d-confusion.png and 3d-worst-N.png for the worst frames kept; the paths written."""
    written = [save_png(folder / "3d-errors.png", error_histograms(evaluation)),
               save_png(folder / "3d-confusion.png", confusion_picture(evaluation))]
    for n, worst in enumerate(evaluation.worst, start=1):
        where = worst.truth.index if worst.truth.index is not None else worst.truth.stamp_ns
        caption = f"frame {where}: {worst.errors} misses and false detections (truth green, detections red)"
        truths = [as_truth_shape(o) for o in worst.truth.objects]
        picture = worst_frame_picture(worst.frame, truths, list(worst.detections), caption)
        written.append(save_png(folder / f"3d-worst-{n}.png", picture))
    return written
