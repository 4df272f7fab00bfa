"""COCO's detection evaluation (``COCOeval``, iouType ``bbox``) re-done on plain arrays, step for step, so
that its AP and AR equal ``pycocotools``' to the last bit on the same input (tests compare them, the oracle
being a dev dependency only).

What it follows exactly: box IoU as ``maskApi.c``'s ``bbIou`` (overlap of ``x..x+w`` and ``y..y+h``, over the
union; nothing for a zero overlap); detections ranked by score with a stable merge sort and cut to the last
``maxDets`` (100) per image and category; per IoU threshold .50:.05:.95 each detection in rank order takes
the best still unmatched truth at or above the threshold (a later truth of equal IoU wins, as there); truths
outside an area range are ignored, and so are the detections matched to them or, unmatched, outside it;
per category, the images' detections merged by a stable sort on score, precision made monotone from the
right and read at the 101 recall points 0:.01:1; a category with no truth in the range stays -1 and is left
out of the means. Crowd regions do not exist here (objrec's truth has none).

objrec's detections carry no score: each scores 1.0, so ranks are ties and the stable sorts keep the order
given: images in the order they were scored, detections in the order the detector reported them. The
12 summary figures are ``COCOeval.stats``' 12, in its order (:data:`STAT_NAMES`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

IOU_THRESHOLDS = np.linspace(.5, 0.95, int(np.round((0.95 - .5) / .05)) + 1, endpoint=True)
RECALL_POINTS = np.linspace(.0, 1.00, int(np.round((1.00 - .0) / .01)) + 1, endpoint=True)
MAX_DETECTIONS = (1, 10, 100)
AREA_RANGES = ((0 ** 2, 1e5 ** 2), (0 ** 2, 32 ** 2), (32 ** 2, 96 ** 2), (96 ** 2, 1e5 ** 2))
AREA_NAMES = ("all", "small", "medium", "large")
#: ``COCOeval.stats`` in order: AP at IoU .50:.95, .50, .75, by area; AR at 1, 10, 100 detections, by area.
STAT_NAMES = ("ap", "ap50", "ap75", "ap_small", "ap_medium", "ap_large",
              "ar1", "ar10", "ar", "ar_small", "ar_medium", "ar_large")


@dataclass(frozen=True)
class Boxes:
    """The truths and detections of one category in one image: ``truth`` G x 4 and ``detected`` D x 4 boxes
    (``x, y, width, height``), ``truth_area`` (COCO's stored area: the polygons', else the box's) and the
    detections' ``scores`` (all 1.0 for objrec)."""

    truth: np.ndarray
    truth_area: np.ndarray
    detected: np.ndarray
    scores: np.ndarray

    @classmethod
    def of(cls, truth: Sequence[Sequence[float]], truth_area: Sequence[float], detected: Sequence[Sequence[float]],
           scores: Sequence[float] | None = None) -> Boxes:
        return cls(np.asarray(truth, dtype=np.float64).reshape(-1, 4), np.asarray(truth_area, dtype=np.float64),
                   np.asarray(detected, dtype=np.float64).reshape(-1, 4),
                   np.ones(len(detected)) if scores is None else np.asarray(scores, dtype=np.float64))


def box_iou(detected: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """D x G IoU of ``x, y, w, h`` boxes, computed as ``bbIou`` computes it (same operations, same order)."""
    d = detected[:, None, :]
    g = truth[None, :, :]
    w = np.minimum(d[..., 2] + d[..., 0], g[..., 2] + g[..., 0]) - np.maximum(d[..., 0], g[..., 0])
    h = np.minimum(d[..., 3] + d[..., 1], g[..., 3] + g[..., 1]) - np.maximum(d[..., 1], g[..., 1])
    inter = w * h
    union = d[..., 2] * d[..., 3] + g[..., 2] * g[..., 3] - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        iou = inter / union
    return np.where((w > 0) & (h > 0), iou, 0.0)


@dataclass
class _Matched:
    """evaluateImg's result for one image, category and area range."""

    matched: np.ndarray  # T x D, a detection matched a truth
    ignored: np.ndarray  # T x D, a detection ignored
    truth_ignored: np.ndarray  # G
    scores: np.ndarray  # D


def _evaluate_image(boxes: Boxes, area: tuple[float, float]) -> _Matched | None:
    if len(boxes.truth) == 0 and len(boxes.detected) == 0:
        return None
    max_det = MAX_DETECTIONS[-1]
    order = np.argsort(-boxes.scores, kind="mergesort")[:max_det]
    detected = boxes.detected[order]
    ious = box_iou(detected, boxes.truth)
    outside = (boxes.truth_area < area[0]) | (boxes.truth_area > area[1])
    truth_order = np.argsort(outside.astype(np.int64), kind="mergesort")
    truth_ignored = outside[truth_order]
    ious = ious[:, truth_order]
    n_t, n_g, n_d = len(IOU_THRESHOLDS), len(truth_order), len(detected)
    truth_matched = np.zeros((n_t, n_g), dtype=bool)
    matched = np.zeros((n_t, n_d), dtype=bool)
    ignored = np.zeros((n_t, n_d), dtype=bool)
    if n_g and n_d:
        rows = ious.tolist()
        ignore = truth_ignored.tolist()
        for t_index, threshold in enumerate(IOU_THRESHOLDS.tolist()):
            taken = truth_matched[t_index]
            for d_index in range(n_d):
                best = min(threshold, 1 - 1e-10)
                m = -1
                row = rows[d_index]
                for g_index in range(n_g):
                    if taken[g_index]:
                        continue
                    if m > -1 and not ignore[m] and ignore[g_index]:
                        break
                    if row[g_index] < best:
                        continue
                    best = row[g_index]
                    m = g_index
                if m == -1:
                    continue
                ignored[t_index, d_index] = ignore[m]
                matched[t_index, d_index] = True
                taken[m] = True
    detected_area = detected[:, 2] * detected[:, 3]
    outside_d = ((detected_area < area[0]) | (detected_area > area[1]))[None, :]
    ignored = ignored | (~matched & np.repeat(outside_d, n_t, 0))
    return _Matched(matched, ignored, truth_ignored, boxes.scores[order])


@dataclass(frozen=True)
class CocoResult:
    """``COCOeval.eval``'s ``precision`` (T x R x K x A x M) and ``recall`` (T x K x A x M), -1 where a category
    has no truth, and ``stats`` (the 12 summary figures, -1 where nothing defines them)."""

    precision: np.ndarray
    recall: np.ndarray
    stats: np.ndarray

    def category(self, k: int) -> dict[str, float]:
        """AP, AP50, AP75 and AR (100 detections) of category ``k`` alone (-1: it has no truth)."""
        return {"ap": _mean(self.precision[:, :, k, 0, 2]), "ap50": _mean(self.precision[0, :, k, 0, 2]),
                "ap75": _mean(self.precision[5, :, k, 0, 2]), "ar": _mean(self.recall[:, k, 0, 2])}

    def curve(self, k: int, iou_index: int = 0) -> np.ndarray:
        """Category ``k``'s interpolated precision at the 101 recall points (IoU threshold ``iou_index``: 0 is
        .50), all areas, 100 detections; -1 where it has no truth."""
        return self.precision[iou_index, :, k, 0, 2]


def coco_evaluate(images: Sequence[Sequence[Boxes]], n_categories: int) -> CocoResult:
    """``images[i][k]``: the boxes of category ``k`` in image ``i`` (images in the order they rank on ties)."""
    n_t, n_r, n_a, n_m = len(IOU_THRESHOLDS), len(RECALL_POINTS), len(AREA_RANGES), len(MAX_DETECTIONS)
    precision = -np.ones((n_t, n_r, n_categories, n_a, n_m))
    recall = -np.ones((n_t, n_categories, n_a, n_m))
    for k in range(n_categories):
        for a, area in enumerate(AREA_RANGES):
            found = [_evaluate_image(image[k], area) for image in images]
            evaluated = [e for e in found if e is not None]
            if not evaluated:
                continue
            for m, max_det in enumerate(MAX_DETECTIONS):
                _accumulate(evaluated, max_det, precision[:, :, k, a, m], recall[:, k, a, m])
    stats = np.array([
        _summary(precision, None, 0, 2), _summary(precision, 0, 0, 2), _summary(precision, 5, 0, 2),
        _summary(precision, None, 1, 2), _summary(precision, None, 2, 2), _summary(precision, None, 3, 2),
        _summary(recall, None, 0, 0), _summary(recall, None, 0, 1), _summary(recall, None, 0, 2),
        _summary(recall, None, 1, 2), _summary(recall, None, 2, 2), _summary(recall, None, 3, 2),
    ])
    return CocoResult(precision, recall, stats)


def _accumulate(evaluated: list[_Matched], max_det: int, precision: np.ndarray, recall: np.ndarray) -> None:
    scores = np.concatenate([e.scores[0:max_det] for e in evaluated])
    order = np.argsort(-scores, kind="mergesort")
    matched = np.concatenate([e.matched[:, 0:max_det] for e in evaluated], axis=1)[:, order]
    ignored = np.concatenate([e.ignored[:, 0:max_det] for e in evaluated], axis=1)[:, order]
    truth_ignored = np.concatenate([e.truth_ignored for e in evaluated])
    n_truth = np.count_nonzero(truth_ignored == 0)
    if n_truth == 0:
        return
    tps = np.logical_and(matched, np.logical_not(ignored))
    fps = np.logical_and(np.logical_not(matched), np.logical_not(ignored))
    tp_sum = np.cumsum(tps, axis=1).astype(dtype=float)
    fp_sum = np.cumsum(fps, axis=1).astype(dtype=float)
    for t, (tp, fp) in enumerate(zip(tp_sum, fp_sum, strict=True)):
        nd = len(tp)
        rc = tp / n_truth
        pr = (tp / (fp + tp + np.spacing(1))).tolist()
        recall[t] = rc[-1] if nd else 0
        for i in range(nd - 1, 0, -1):
            if pr[i] > pr[i - 1]:
                pr[i - 1] = pr[i]
        q = np.zeros(len(RECALL_POINTS))
        for ri, pi in enumerate(np.searchsorted(rc, RECALL_POINTS, side="left")):
            if pi >= nd:
                break
            q[ri] = pr[pi]
        precision[t] = q


def _summary(values: np.ndarray, iou_index: int | None, area: int, max_det: int) -> float:
    """``COCOeval.summarize``'s mean of the defined (> -1) entries, -1 when there are none."""
    s = values if iou_index is None else values[[iou_index]]
    s = s[..., area:area + 1, max_det:max_det + 1]
    return _mean(s)


def _mean(s: np.ndarray) -> float:
    defined = s[s > -1]
    return -1.0 if len(defined) == 0 else float(np.mean(defined))
