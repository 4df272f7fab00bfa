"""The HSV eyedropper: drag a rectangle on a colour object and the HSV filter's ranges fit its pixels.

Finding six thresholds by moving sliders is the slowest part of tuning a colour system; the pixels the user
points at already say what the ranges should be. Robust percentiles (not the extremes) keep a few stray
background or highlight pixels in the rectangle from opening the range to everything, and the hue is
measured on the circle, so red (hues on both sides of 0) gives a wrapping range (``h_min > h_max``) instead
of "every hue". The six values go to the filter in ONE ``set_parameters`` call: one change, one undo step.

The eyedropper is on while its toolbar button is checked, or for one drag made with Shift held; otherwise a
drag gives a target to the detectors as before. The filter is found by its parameters (any module with
h/s/v min/max), so the window names no kind package.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
from PySide6.QtCore import QObject, Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QToolBar, QWidget

from objrec_core import RecognitionSystem, Rect, StageResults

#: The parameters that make a module an HSV filter for the eyedropper.
HSV_PARAMETERS = ("h_min", "h_max", "s_min", "s_max", "v_min", "v_max")
HUE_PERIOD = 180  # OpenCV's 8-bit hue: 0..179
#: Percentiles of the pixels the ranges span: the outer 1 % each side are strays (noise, edges).
LOW, HIGH = 1.0, 99.0
#: Added beyond the percentiles, so the pixels of the same object in the next frames (noise, shading) stay in.
HUE_MARGIN, SV_MARGIN = 3, 20


def hsv_ranges(bgr: np.ndarray, low: float = LOW, high: float = HIGH) -> dict[str, int]:
    """The HSV filter values that keep the pixels of ``bgr`` (H x W x 3, or N x 3, uint8 BGR).

    Hue is handled on its circle: the pixels are turned so their circular mean sits mid-range, the
    percentiles taken there and turned back, which gives ``h_min > h_max`` (a range wrapping around 0) for
    red. A spread wider than half the circle keeps every hue.
    """
    pixels = np.ascontiguousarray(bgr, dtype=np.uint8).reshape(-1, 1, 3)
    if pixels.shape[0] == 0:
        raise ValueError("no pixels to measure")
    hsv = cv2.cvtColor(pixels, cv2.COLOR_BGR2HSV).reshape(-1, 3).astype(np.float64)
    hue, sat, val = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    angle = hue * (2 * np.pi / HUE_PERIOD)
    mean = np.arctan2(np.sin(angle).mean(), np.cos(angle).mean()) * HUE_PERIOD / (2 * np.pi)
    shift = HUE_PERIOD / 2 - mean
    turned = np.mod(hue + shift, HUE_PERIOD)
    h_lo, h_hi = np.percentile(turned, [low, high])
    h_lo, h_hi = h_lo - HUE_MARGIN, h_hi + HUE_MARGIN
    if h_hi - h_lo >= HUE_PERIOD / 2 + 2 * HUE_MARGIN:
        h_min, h_max = 0, HUE_PERIOD - 1
    else:
        h_min = int(np.floor(np.mod(h_lo - shift, HUE_PERIOD)))
        h_max = int(np.ceil(np.mod(h_hi - shift, HUE_PERIOD))) % HUE_PERIOD
    s_lo, s_hi = np.percentile(sat, [low, high])
    v_lo, v_hi = np.percentile(val, [low, high])
    return {
        "h_min": h_min,
        "h_max": h_max,
        "s_min": int(max(0, np.floor(s_lo - SV_MARGIN))),
        "s_max": int(min(255, np.ceil(s_hi + SV_MARGIN))),
        "v_min": int(max(0, np.floor(v_lo - SV_MARGIN))),
        "v_max": int(min(255, np.ceil(v_hi + SV_MARGIN))),
    }


def hsv_filter_of(system: RecognitionSystem) -> Any | None:
    """The first module with the six HSV range parameters, or None."""
    for module in system.modules:
        names = {spec.name for spec in module.parameter_specs()}
        if all(name in names for name in HSV_PARAMETERS):
            return module
    return None


class Eyedropper(QObject):
    """The eyedropper of a definition window: a checkable action on a toolbar of its own and the picking.

    ``report(text, error)`` shows what was set (or why nothing was).
    """

    def __init__(self, system: RecognitionSystem, report: Callable[[str, bool], None], parent: QWidget) -> None:
        super().__init__(parent)
        self.system = system
        self.report = report
        self.action = QAction("HSV eyedropper", parent, checkable=True)
        self.action.setShortcut(QKeySequence("Ctrl+E"))
        self.action.setToolTip("Drag a rectangle on a coloured object to set the HSV filter's ranges from its "
                               "pixels (Ctrl+E; or hold Shift while dragging)")
        self.toolbar = QToolBar("Tuning", parent)
        self.toolbar.setObjectName("tuning_toolbar")
        self.toolbar.addAction(self.action)

    def wants(self, modifiers: Any) -> bool:
        """Whether a drag made with these keyboard modifiers is for the eyedropper."""
        shift = bool(modifiers is not None and modifiers & Qt.KeyboardModifier.ShiftModifier)
        return self.action.isChecked() or shift

    def pick(self, rect: Rect, results: StageResults) -> dict[str, int] | None:
        """Set the HSV filter's ranges from the frame's pixels in ``rect``; the values set, or None."""
        module = hsv_filter_of(self.system)
        if module is None:
            self.report("eyedropper: the pipeline has no HSV filter (add one from the Pipeline menu)", True)
            return None
        data = results.frame.data
        if not (isinstance(data, np.ndarray) and data.ndim == 3 and data.shape[2] == 3 and data.dtype == np.uint8):
            self.report("eyedropper: the frame is not a colour picture (8-bit BGR), so it has no hues to take", True)
            return None
        patch = data[rect.y:rect.y + rect.height, rect.x:rect.x + rect.width]
        if patch.size == 0:
            self.report("eyedropper: the rectangle holds no pixels", True)
            return None
        values = hsv_ranges(patch)
        try:
            module.set_parameters(**values)  # one call: one change event, one undo step
        except ValueError as exc:
            self.report(f"eyedropper: {module.id} refused the ranges: {exc}", True)
            return None
        wrap = " (wrapping around 0)" if values["h_min"] > values["h_max"] else ""
        self.report(
            f"eyedropper: {module.id} set from {rect.width}×{rect.height} pixels: "
            f"hue {values['h_min']}..{values['h_max']}{wrap}, saturation {values['s_min']}..{values['s_max']}, "
            f"value {values['v_min']}..{values['v_max']}",
            False,
        )
        return values
