"""The 2D evaluation's pictures: the precision-recall curves and the worst frames, drawn with OpenCV (no
plotting library is needed at run time), saved as PNG atomically."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from strictio import OutputError, write_atomically
from strictio.shown import drawable

from .base import as_bgr
from .evaluation_coco import RECALL_POINTS
from .truth import TruthObject2D

GREEN, RED, GREY, INK, GRID = (80, 230, 80), (60, 60, 255), (170, 170, 170), (30, 30, 30), (215, 215, 215)
RIM = (20, 20, 20)
CURVE_COLOURS = [(200, 90, 30), (40, 40, 230), (60, 160, 60), (0, 150, 230), (170, 60, 170), (120, 120, 20),
                 (30, 30, 30), (90, 90, 200)]
FONT = cv2.FONT_HERSHEY_SIMPLEX


def save_png(path: Path, picture: np.ndarray) -> Path:
    """Write ``picture`` (BGR) as a PNG, atomically."""
    ok, encoded = cv2.imencode(".png", picture)
    if not ok:
        raise OutputError(str(path), "OpenCV could not encode the picture as PNG")
    write_atomically(path, encoded.tobytes())
    return path


def precision_recall_picture(curves: Sequence[tuple[str, np.ndarray, float]], title: str,
                             size: tuple[int, int] = (800, 600)) -> np.ndarray:
    """Each ``(name, precision at the 101 recall points, AP)`` as a line on a precision-over-recall chart."""
    width, height = size
    left, right, top, bottom = 70, 250, 50, 60
    canvas = np.full((height, width, 3), 255, np.uint8)
    plot_w, plot_h = width - left - right, height - top - bottom

    def at(recall: float, precision: float) -> tuple[int, int]:
        return round(float(left + recall * plot_w)), round(float(top + (1 - precision) * plot_h))

    for tick in np.linspace(0, 1, 11):
        cv2.line(canvas, at(tick, 0), at(tick, 1), GRID, 1)
        cv2.line(canvas, at(0, tick), at(1, tick), GRID, 1)
        x, y = at(tick, 0)
        cv2.putText(canvas, drawable(f"{tick:.1f}"), (x - 12, y + 20), FONT, 0.45, INK, 1, cv2.LINE_AA)
        x, y = at(0, tick)
        cv2.putText(canvas, drawable(f"{tick:.1f}"), (x - 40, y + 5), FONT, 0.45, INK, 1, cv2.LINE_AA)
    cv2.rectangle(canvas, at(0, 1), at(1, 0), INK, 1)
    cv2.putText(canvas, "recall", (left + plot_w // 2 - 25, height - 15), FONT, 0.6, INK, 1, cv2.LINE_AA)
    cv2.putText(canvas, "precision", (8, top - 8), FONT, 0.5, INK, 1, cv2.LINE_AA)
    cv2.putText(canvas, drawable(title), (left, 20), FONT, 0.55, INK, 1, cv2.LINE_AA)
    for n, (name, precision, ap) in enumerate(curves):
        colour = CURVE_COLOURS[n % len(CURVE_COLOURS)]
        points = np.array([at(r, p) for r, p in zip(RECALL_POINTS, precision, strict=True) if p > -1], np.int32)
        if len(points):
            cv2.polylines(canvas, [points], False, colour, 2, cv2.LINE_AA)
        y = top + 20 + 24 * n
        cv2.line(canvas, (width - right + 15, y - 5), (width - right + 40, y - 5), colour, 2, cv2.LINE_AA)
        label = f"{name[:20]}  AP50 {ap:.2f}" if ap > -1 else f"{name[:20]}  no truth"
        cv2.putText(canvas, drawable(label), (width - right + 46, y), FONT, 0.45, INK, 1, cv2.LINE_AA)
    return canvas


def frame_picture(image: np.ndarray, truth: Sequence[TruthObject2D],
                  detected: Sequence[tuple[str, Sequence[tuple[float, float]]]], title: str,
                  unscored: Sequence[TruthObject2D] = ()) -> np.ndarray:
    """The frame with its truth (green: outline, or box) and its detections (red: outline) drawn, names beside
    them, truth no scored name covers in grey, and ``title`` (which frame, what went wrong) in a band above.
    Lines and names have a dark rim so that they show on any colour (a green truth on a green object)."""
    canvas = as_bgr(image).copy()
    for objects, colour in ((unscored, GREY), (truth, GREEN)):
        for obj in objects:
            outlines = [np.asarray(o, np.float64) for o in obj.outlines]
            if not outlines or obj.box is not None:
                x, y, w, h = obj.bbox
                outlines.append(np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]]))
            for outline in outlines:
                _line(canvas, outline, colour)
            x, y, _w, h = obj.bbox
            _label(canvas, obj.name, (int(x), int(y + h) + 16), colour)
    for name, polygon in detected:
        if len(polygon) == 0:
            continue
        points = np.asarray(polygon, np.float64)
        _line(canvas, points, RED)
        x, y = points.min(axis=0)
        _label(canvas, name, (int(x), max(14, int(y) - 6)), RED)
    band = np.full((28, canvas.shape[1], 3), 255, np.uint8)
    cv2.putText(band, drawable(title), (6, 19), FONT, 0.5, INK, 1, cv2.LINE_AA)
    return np.vstack([band, canvas])


def _line(canvas: np.ndarray, points: np.ndarray, colour: tuple[int, int, int]) -> None:
    closed = [np.round(points).astype(np.int32)]
    cv2.polylines(canvas, closed, True, RIM, 4, cv2.LINE_AA)
    cv2.polylines(canvas, closed, True, colour, 2, cv2.LINE_AA)


def _label(canvas: np.ndarray, text: str, at: tuple[int, int], colour: tuple[int, int, int]) -> None:
    cv2.putText(canvas, drawable(text), at, FONT, 0.5, RIM, 3, cv2.LINE_AA)
    cv2.putText(canvas, drawable(text), at, FONT, 0.5, colour, 1, cv2.LINE_AA)
