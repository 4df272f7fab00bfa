"""The ``signal`` kind: 1-D float arrays, peaks as detected objects, plots drawn with NumPy alone."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from objrec_core import DetectedObjectArray, Frame, FrameKindError, Header, Kind, Outline

#: Plot size: one column per sample up to MAX_COLUMNS (longer signals share columns), PLOT_HEIGHT rows.
PLOT_HEIGHT = 160
MAX_COLUMNS = 2048
MARGIN = 8
BACKGROUND = (32, 32, 32)  # BGR
TRACE = (80, 220, 80)
MARK = (60, 60, 240)


@dataclass(frozen=True)
class SignalPeak:
    """One peak: the detector's object name, the sample it is at, and the signal's value there."""

    name: str
    position: int
    height: float

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "position": self.position, "height": self.height}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SignalPeak:
        return cls(str(data["name"]), int(data["position"]), float(data["height"]))


class SignalPeakArray(DetectedObjectArray):
    """The peaks found in one frame; ``from_dict`` rebuilds typed peaks from a JSON line."""

    object_type = SignalPeak

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SignalPeakArray:
        return cls(header=Header.from_dict(data.get("header", {})),
                   objects=[SignalPeak.from_dict(o) for o in data.get("objects", [])])


def _columns(samples: int) -> tuple[int, int]:
    """Samples per column and the number of columns of a signal's plot."""
    per_column = max(1, math.ceil(samples / MAX_COLUMNS))
    return per_column, math.ceil(samples / per_column)


def plot_signal(data: np.ndarray) -> np.ndarray:
    """A BGR picture of the signal: each column spans the samples it covers and joins its neighbours, so
    a spike one sample wide still shows; the vertical scale runs from the lowest to the highest value."""
    values = np.asarray(data, dtype=np.float64)
    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    values = np.where(np.isfinite(values), values, lo)
    per_column, columns = _columns(values.size)
    starts = np.arange(0, values.size, per_column)
    column_low = np.minimum.reduceat(values, starts)
    column_high = np.maximum.reduceat(values, starts)
    rows = PLOT_HEIGHT - 2 * MARGIN
    scale = (rows - 1) / (hi - lo) if hi > lo else 0.0

    def row_of(v: np.ndarray) -> np.ndarray:
        return (MARGIN + rows - 1 - np.rint((v - lo) * scale)).astype(np.int64)

    top, bottom = row_of(column_high), row_of(column_low)  # rows grow downwards: top <= bottom
    # Reach up or down to the previous column, so a steep slope draws as a line rather than dots.
    joined_top, joined_bottom = top.copy(), bottom.copy()
    joined_top[1:] = np.minimum(top[1:], bottom[:-1])
    joined_bottom[1:] = np.maximum(bottom[1:], top[:-1])
    top, bottom = joined_top, joined_bottom
    picture = np.empty((PLOT_HEIGHT, columns + 2 * MARGIN, 3), dtype=np.uint8)
    picture[:] = BACKGROUND
    y = np.arange(PLOT_HEIGHT)[:, None]
    trace = (y >= top[None, :]) & (y <= bottom[None, :])
    picture[:, MARGIN:MARGIN + columns][trace] = TRACE
    return picture


class SignalKind(Kind):
    """Frames are non-empty 1-D float arrays; filters keep them so; detectors report ``SignalPeakArray``."""

    name = "signal"
    title = "1-D signals"
    object_array_type = SignalPeakArray
    demo_spec = "wave"

    def check_frame(self, data: Any) -> None:
        if not isinstance(data, np.ndarray):
            raise FrameKindError(f"expected a 1-D signal (a NumPy float array), got {type(data).__name__}")
        if data.ndim != 1 or data.size == 0 or data.dtype.kind != "f":
            raise FrameKindError(
                f"expected a non-empty 1-D float array, got a {data.dtype} array of shape {data.shape}"
            )

    def preview(self, data: Any) -> np.ndarray:
        self.check_frame(data)
        return plot_signal(data)

    def annotate(self, frame: Frame, objects: DetectedObjectArray) -> np.ndarray:
        """The plot with a vertical line through each peak, behind the trace."""
        picture = self.preview(frame.data)
        per_column, columns = _columns(frame.data.size)
        for peak in objects.objects:
            column = int(peak.position) // per_column
            if 0 <= column < columns:
                line = picture[:, MARGIN + column]
                line[(line == BACKGROUND).all(axis=1)] = MARK
        return picture

    def outlines(self, objects: DetectedObjectArray) -> list[Outline]:
        return [Outline(f"{peak.name} @{peak.position}") for peak in objects.objects]

    def copy_frame(self, data: Any) -> Any:
        return data.copy() if isinstance(data, np.ndarray) else super().copy_frame(data)
