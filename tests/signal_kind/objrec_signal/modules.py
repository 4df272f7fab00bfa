"""The signal kind's modules: a moving-average filter and a peak detector."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from objrec_core import Choice, DetectedObjectArray, Detector, Filter, Float, Int, Ordered
from objrec_core.modules import Detections

from .kind import SignalPeak, SignalPeakArray

#: ``edges`` choices and the np.pad modes they stand for.
EDGE_MODES = {"reflect": "reflect", "edge": "edge", "zero": "constant"}


class MovingAverageFilter(Filter):
    """Each sample becomes the mean of the ``window`` samples centred on it: noise falls by about the square
    root of the window, while a peak wider than the window keeps its place."""

    kind = "signal"

    window = Int(5, "samples averaged; odd, so the average is centred on its sample", min=1, max=201, step=2,
                 soft_max=51)
    edges = Choice("reflect", list(EDGE_MODES), "how the signal goes on past its ends: mirrored, held, or zero")

    def filter(self, frame: np.ndarray) -> np.ndarray:
        p = self.params
        samples = np.asarray(frame, dtype=np.float64)
        window = min(p.window, samples.size if samples.size % 2 else samples.size - 1)  # never wider than the signal
        if window <= 1:
            return samples.copy()
        half = window // 2
        padded = np.pad(samples, half, mode=EDGE_MODES[p.edges])
        return np.convolve(padded, np.full(window, 1.0 / window), mode="valid")


class PeakDetector(Detector):
    """Local maxima above ``threshold`` (and not above ``ceiling``: a clipped sensor is no peak); of two
    closer than ``min_distance`` samples only the higher one is reported."""

    kind = "signal"
    object_array_type: ClassVar[type[DetectedObjectArray]] = SignalPeakArray

    threshold = Float(0.5, "a peak must rise above this value", min=-1000.0, max=1000.0, soft_min=-1.0,
                      soft_max=10.0, step=0.05)
    ceiling = Float(100.0, "peaks above this value are clipping, not objects", min=-1000.0, max=1000.0,
                    soft_min=0.0, soft_max=200.0, step=1.0)
    min_distance = Int(5, "samples between two reported peaks at least; the higher one wins", min=1, max=10000,
                       soft_max=200)
    levels = Ordered("threshold", "ceiling", strict=True, why="no peak could be reported")

    def detect(self, frame: np.ndarray) -> Detections:
        """The peaks, or why there are none: the reason travels with the result (no state kept here)."""
        p = self.params
        x = np.asarray(frame, dtype=np.float64)
        if x.size < 3:
            return Detections([], f"{x.size} samples: a peak needs a sample on each side")
        inner = x[1:-1]
        # >= on the left, > on the right: a flat top counts once, at its last sample. NaN compares false.
        peak = (inner >= x[:-2]) & (inner > x[2:]) & (inner > p.threshold) & (inner <= p.ceiling)
        candidates = np.flatnonzero(peak) + 1
        order = candidates[np.argsort(-x[candidates], kind="stable")]
        taken = np.zeros(x.size, dtype=bool)
        kept = []
        for index in order:
            if taken[index]:
                continue
            kept.append(int(index))
            taken[max(0, index - p.min_distance + 1):index + p.min_distance] = True
        name = self.object_name
        peaks = [SignalPeak(name, index, float(x[index])) for index in sorted(kept)]
        return Detections(peaks, None if peaks else self._reason(x, p))

    @staticmethod
    def _reason(x: np.ndarray, p: Any) -> str:
        """Why a frame has no peak, with the number to tune by."""
        inner = x[1:-1]
        finite = inner[np.isfinite(inner)]
        if finite.size == 0:
            return "no finite sample"
        if finite.max() <= p.threshold:
            return f"no sample above threshold {p.threshold:g} (highest {finite.max():.3g})"
        return f"every sample above threshold {p.threshold:g} is above ceiling {p.ceiling:g} or on a slope"
