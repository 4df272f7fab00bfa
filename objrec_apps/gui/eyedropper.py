"""The HSV eyedropper: drag a rectangle on a colour object and the HSV filter's ranges fit its pixels.

Finding six thresholds by moving sliders is the slowest part of tuning a colour system; the pixels the user
points at already say what the ranges should be. A rectangle drawn loosely round an object also holds
background, the object's specular highlights and perhaps a neighbour: only the pixels of its dominant colour
are measured (saturation and value gates, then the largest hue cluster, then the largest brightness cluster;
``object_pixels``), and robust percentiles (not the extremes) of those set the ranges, the hue's grown by the
object's own hue spread on each side (``semi_deviations``). The hue is measured on
the circle, so red (hues on both sides of 0) gives a wrapping range (``h_min > h_max``) instead of "every
hue". The six values go to the filter in ONE ``set_parameters`` call: one change, one undo step.

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
#: Percentiles of the object's pixels the ranges span: the outer 1 % each side are strays (noise, edges).
LOW, HIGH = 1.0, 99.0
#: Added beyond the percentiles, so the pixels of the same object in the next frames (noise, shading) stay in.
#: The hue margin is at least ``HUE_MARGIN``, and on each side at least the object's own hue spread on that side
#: (its semi-deviation from the median hue): a colour whose shading already runs far along the hue circle (a
#: glossy blue candy runs from 101 to 124 and, on candies turned a little further, on to 130) has more of it
#: on the next object of its colour. It never reaches onto the hues of another cluster in the rectangle.
HUE_MARGIN, SV_MARGIN = 2, 20
#: A pixel has a hue worth taking when it is this saturated and this bright: white background, grey shadows
#: and specular highlights (saturation near 0) and black (value near 0) have hues that are only noise.
SATURATION_GATE, VALUE_GATE = 40, 20
#: Two neighbouring histogram peaks, one of them made of pure primaries (``at_gamut_corner``), are one colour
#: unless the valley between them falls under this share of the lower peak: an orange candy's most saturated
#: part is clipped to pure red, the red candies' own colour, and forms a peak of its own next to its orange
#: hues. Other neighbouring peaks are the object's own shading and always one colour (the shadowed side of a
#: blue candy forms a peak at hue 129-130, beside its body's 101-124).
VALLEY_SHARE = 0.2
#: The value histogram's bin width: wide enough to smooth noise, narrow enough to part brown from red.
VALUE_BIN = 8
#: The brightness kept is the run of value bins round the peak holding at least this share of its count.
VALUE_CORE = 0.03
#: Fewer gated pixels than this share of the rectangle: the object itself is grey, so all pixels are measured.
MIN_GATED_SHARE = 0.05


def at_gamut_corner(hsv: np.ndarray) -> np.ndarray:
    """Which rows of ``hsv`` (N x 3, OpenCV HSV) are pure red, green or blue at full saturation: two channels
    at 0, a corner of the sensor's gamut. Every saturated colour within reach of that primary (orange, pink,
    purple) clips to the same pixel, so such a peak says nothing of which of them the object is."""
    return (hsv[:, 1] == 255) & (hsv[:, 0] % (HUE_PERIOD // 3) == 0)


def histogram_clusters(counts: np.ndarray, *, circular: bool, corner: np.ndarray | None = None) -> list[np.ndarray]:
    """The non-empty bins of ``counts`` grouped by colour: each an array of bin indices in order along the
    axis (a circular cluster may wrap past the last bin). Empty bins always separate clusters; inside a run
    of non-empty bins, the run is cut at its local minima and neighbouring parts are merged again unless the
    valley between them is under ``VALLEY_SHARE`` of the lower of their two peaks and one of the two peaks is
    a ``corner`` bin (a boolean per bin; None: every bin, so any deep valley separates)."""
    n = len(counts)
    if not counts.any():
        return []
    order = np.arange(n)
    if circular:  # start the walk on an empty bin (or on the lowest one) so no run is cut by the array's end
        order = np.roll(order, -int(np.argmin(counts)))
    clusters: list[np.ndarray] = []
    run: list[int] = []
    for index in [*order.tolist(), -1]:
        if index >= 0 and counts[index] > 0:
            run.append(index)
            continue
        if run:
            clusters.extend(_split_run(counts, np.asarray(run), corner))
        run = []
    return clusters


def _split_run(counts: np.ndarray, run: np.ndarray, corner: np.ndarray | None) -> list[np.ndarray]:
    values = counts[run].astype(np.float64)
    separable = np.ones(len(run), bool) if corner is None else corner[run]
    cuts = [i for i in range(1, len(values) - 1) if values[i] <= values[i - 1] and values[i] < values[i + 1]]
    parts = [list(range(a, b)) for a, b in zip([0, *cuts], [*cuts, len(values)], strict=True)]
    while len(parts) > 1:
        ratios = [_valley(values, separable, parts[k], parts[k + 1]) for k in range(len(parts) - 1)]
        best = int(np.argmax(ratios))
        if ratios[best] < VALLEY_SHARE:
            break
        parts[best:best + 2] = [parts[best] + parts[best + 1]]
    return [run[part] for part in parts]


def _valley(values: np.ndarray, separable: np.ndarray, left: list[int], right: list[int]) -> float:
    """The valley between two neighbouring parts of a run as a share of their lower peak; 1 (never parted)
    where neither peak is ``separable``."""
    peaks = (left[int(np.argmax(values[left]))], right[int(np.argmax(values[right]))])
    if not separable[list(peaks)].any():
        return 1.0
    return float(values[right[0]] / min(values[left].max(), values[right].max()))


def largest_cluster(values: np.ndarray, bins: int, *, width: int = 1, circular: bool = False,
                    core: float = 0.0, corner: np.ndarray | None = None) -> np.ndarray:
    """Which of ``values`` (integers in 0..bins*width-1) fall in the most populated cluster of their histogram
    (bins of ``width`` values; see ``histogram_clusters``), as a boolean array. ``core`` > 0 keeps only the
    bins around the cluster's peak down to where the count first falls under that share of the peak: the
    long thin shoulder of pixels between two objects (an edge where a red candy's shading runs into a brown
    one) is left out. ``corner`` (a boolean per value, see ``at_gamut_corner``) marks the values whose peak
    may part from its neighbour at a deep valley; None: any peak may."""
    binned = values // width
    counts = np.bincount(binned, minlength=bins)
    corner_bins = None
    if corner is not None:  # a bin is a corner bin when most of its values are
        corner_bins = 2 * np.bincount(binned, weights=corner.astype(np.float64), minlength=bins) > counts
    clusters = histogram_clusters(counts, circular=circular, corner=corner_bins)
    best = max(clusters, key=lambda bins_: int(counts[bins_].sum()))
    if core > 0:
        along = counts[best]
        top = int(np.argmax(along))
        low = along >= core * along[top]
        first = top - int(np.argmin(low[top::-1])) + 1 if not low[:top + 1].all() else 0
        last = top + int(np.argmin(low[top:])) - 1 if not low[top:].all() else len(along) - 1
        best = best[first:last + 1]
    return np.isin(binned, best)


def object_pixels(hsv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows of ``hsv`` (N x 3, OpenCV HSV) that belong to the dominant coloured object of a rectangle,
    and which hues the rest of the rectangle's coloured pixels have (a boolean per hue): pixels with a real
    hue (saturation and value gates), then the largest hue cluster (on the circle, so red on both sides of 0
    is one cluster), then the largest brightness cluster within it (brown and red share hues). A rectangle
    with almost no coloured pixel (a grey object) is measured whole."""
    others = np.zeros(HUE_PERIOD, bool)
    gated = hsv[(hsv[:, 1] >= SATURATION_GATE) & (hsv[:, 2] >= VALUE_GATE)]
    if len(gated) < max(1, MIN_GATED_SHARE * len(hsv)):
        return hsv, others
    in_cluster = largest_cluster(gated[:, 0], HUE_PERIOD, circular=True, corner=at_gamut_corner(gated))
    others[gated[~in_cluster, 0]] = True
    gated = gated[in_cluster]
    return gated[largest_cluster(gated[:, 2], 256 // VALUE_BIN, width=VALUE_BIN, core=VALUE_CORE)], others


def hue_range(hue: np.ndarray, low: float, high: float, others: np.ndarray | None = None) -> tuple[int, int]:
    """(h_min, h_max) spanning the ``low``..``high`` percentiles of ``hue`` measured on the circle, widened on
    each side by ``HUE_MARGIN`` or the hues' spread on that side, whichever is larger, but never onto the hues
    of ``others`` (the other colours seen beside the object); h_min > h_max is a range wrapping around 0."""
    counts = np.bincount(hue, minlength=HUE_PERIOD)
    empty = np.flatnonzero(counts == 0)
    if len(empty) == 0:
        return 0, HUE_PERIOD - 1
    # turned so the middle of the widest run of absent hues is 0: the object's hues lie inside, unwrapped
    present = np.flatnonzero(counts)
    gaps = np.diff(np.concatenate([present, [present[0] + HUE_PERIOD]]))  # present hue to the next one
    widest = int(np.argmax(gaps))
    start = int(present[widest] + (gaps[widest] + 1) // 2) % HUE_PERIOD
    turned = np.mod(hue - start, HUE_PERIOD)
    h_lo, h_hi = np.percentile(turned, [low, high])
    lo, hi = int(np.floor(h_lo)), int(np.ceil(h_hi))
    taken = np.zeros(HUE_PERIOD, bool) if others is None else np.roll(others, -start)
    below, above = semi_deviations(turned)
    for _ in range(max(HUE_MARGIN, int(np.ceil(below)))):
        if lo > 0 and not taken[lo - 1]:
            lo -= 1
    for _ in range(max(HUE_MARGIN, int(np.ceil(above)))):
        if hi < HUE_PERIOD - 1 and not taken[(hi + 1) % HUE_PERIOD]:
            hi += 1
    if hi - lo >= HUE_PERIOD - 1:
        return 0, HUE_PERIOD - 1
    return (lo + start) % HUE_PERIOD, (hi + start) % HUE_PERIOD


def semi_deviations(values: np.ndarray) -> tuple[float, float]:
    """The spread of ``values`` below and above their median: the root mean square of the distances on that
    side (counting the values on the other side as 0). A red candy's hues run far below its pure-red peak and
    hardly above it, so its range grows towards pink and not towards orange."""
    deviation = values - np.median(values)
    return (float(np.sqrt(np.mean(np.minimum(deviation, 0) ** 2))),
            float(np.sqrt(np.mean(np.maximum(deviation, 0) ** 2))))


def hsv_ranges(bgr: np.ndarray, low: float = LOW, high: float = HIGH) -> dict[str, int]:
    """The HSV filter values that keep the object in ``bgr`` (H x W x 3, or N x 3, uint8 BGR): the pixels of
    its dominant colour (``object_pixels``: not the background, the highlights or a neighbour caught in the
    rectangle), their ``low``..``high`` percentiles plus margins. Hue is measured on its circle, which gives
    ``h_min > h_max`` (a range wrapping around 0) for red.
    """
    pixels = np.ascontiguousarray(bgr, dtype=np.uint8).reshape(-1, 1, 3)
    if pixels.shape[0] == 0:
        raise ValueError("no pixels to measure")
    hsv, others = object_pixels(cv2.cvtColor(pixels, cv2.COLOR_BGR2HSV).reshape(-1, 3).astype(np.int64))
    h_min, h_max = hue_range(hsv[:, 0], low, high, others)
    s_lo = np.percentile(hsv[:, 1], low)
    v_lo, v_hi = np.percentile(hsv[:, 2], [low, high])
    return {
        "h_min": h_min,
        "h_max": h_max,
        "s_min": int(max(0, np.floor(s_lo - SV_MARGIN))),
        "s_max": 255,  # more saturated than the object is still its colour, never the background
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


TOOLTIP = ("Drag a rectangle on a coloured object to set the HSV filter's ranges from its pixels (Ctrl+E; or hold "
           "Shift while dragging)")
NO_FILTER_TOOLTIP = ("The HSV eyedropper sets an HSV filter's ranges from the pixels of a rectangle; this pipeline "
                     "has no HSV filter (add one from the Pipeline menu)")


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
        self.toolbar = QToolBar("Tuning", parent)
        self.toolbar.setObjectName("tuning_toolbar")
        self.toolbar.addAction(self.action)
        self.follow_pipeline()

    def follow_pipeline(self) -> None:
        """Enabled while the pipeline has an HSV filter to set, greyed out (its tooltip saying why) while it has
        none: on a feature or a 3D pipeline the button could only ever answer that there is nothing to set."""
        usable = hsv_filter_of(self.system) is not None
        if not usable and self.action.isChecked():
            self.action.setChecked(False)  # drags go to the detectors again
        self.action.setEnabled(usable)
        self.action.setToolTip(TOOLTIP if usable else NO_FILTER_TOOLTIP)

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
