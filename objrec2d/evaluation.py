"""Scoring 2D detections against 2D truth: precision, recall and F1 at IoU 0.5, and COCO's AP and AR.

What is compared: boxes. A truth object's box is its labelled ``bbox`` (else its polygons' bounds), a
detection's the bounds of its polygon: the same boxes for F1 and for AP, so the two figures agree on what a
hit is (COCO's bbox evaluation).

Which objects may match: a detection named ``N`` may be a truth object named ``N`` or of the group ``N``
(COCO's supercategory: the colour demo system names every find ``coloured_object``, its truth names the
shapes ``red``, ``green``... in that group).

Which names are scored (the rows of the table and the "all" figures): the ``names`` option when given; else
the names the detections use, over every frame scored (a system reports one object name: truth it could
never name is not its failure), or, when nothing at all was detected, every truth name. Truth left out that
way is listed as not scored in every report, never silently dropped. Given the truth names as ``names``,
the COCO figures are exactly ``pycocotools``' (which scores every truth category); with the default they are
the same whenever every truth name was detected somewhere.

- Precision, recall, F1 (:attr:`ImageEvaluation.score`, what tuning maximises): per frame and name, the pairs
  of detection and truth with IoU >= 0.5 are taken greedily, best IoU first (ties: detection order, then
  truth order), each detection and each truth used once. F1 = 2TP / (2TP + FP + FN), 1.0 when there was
  nothing to find and nothing found; precision and recall are None where undefined (nothing detected, no
  truth).
- AP@[.50:.95], AP50, AP75, AR (100 detections), and all 12 of ``COCOeval.stats``: :mod:`.evaluation_coco`,
  equal to ``pycocotools`` on the same boxes. objrec's detections have no score: each scores 1.0 and ties
  keep their order (pycocotools' stable merge sort): frames in the order they were added, detections in the
  order the detector reported them. "all" is the mean over the scored names that have truth, as COCO's.
"""

from __future__ import annotations

import heapq
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import DetectedObjectArray, Frame
from objrec_core.evaluation import Evaluation, FrameTruth, Scorer

from .evaluation_coco import STAT_NAMES, Boxes, CocoResult, box_iou, coco_evaluate
from .truth import TruthObject2D, polygon_bbox

log = logging.getLogger(__name__)

#: The bars :meth:`ImageEvaluation.below` knows (``objrec-eval --min-f1`` and the like).
BARS = ("f1", "precision", "recall", "ap", "ap50")
#: Columns of the summary table, in order.
COLUMNS = ("name", "truth", "detected", "tp", "fp", "fn", "precision", "recall", "f1", "ap", "ap50", "ap75", "ar")

Detection = tuple[str, tuple[tuple[float, float], ...], tuple[float, float, float, float]]


@dataclass
class FrameRecord:
    """One scored frame: where it is, its truth and its detections (name, polygon, box)."""

    number: int
    index: int | None
    stamp_ns: int | None
    truth: tuple[TruthObject2D, ...]
    detected: list[Detection]
    image: np.ndarray | None = None

    def name(self) -> str:
        return f"frame {self.index}" if self.index is not None else f"stamp {self.stamp_ns}"


@dataclass
class Counts:
    """True positives, false positives and misses of one name (or all) at the F1 IoU threshold."""

    truth: int = 0
    detected: int = 0
    tp: int = 0

    @property
    def fp(self) -> int:
        return self.detected - self.tp

    @property
    def fn(self) -> int:
        return self.truth - self.tp

    @property
    def precision(self) -> float | None:
        return self.tp / self.detected if self.detected else None

    @property
    def recall(self) -> float | None:
        return self.tp / self.truth if self.truth else None

    @property
    def f1(self) -> float:
        wrong = self.fp + self.fn
        return 1.0 if self.tp == 0 and wrong == 0 else 2 * self.tp / (2 * self.tp + wrong)

    def add(self, other: Counts) -> None:
        self.truth += other.truth
        self.detected += other.detected
        self.tp += other.tp


def match_greedy(truth: np.ndarray, detected: np.ndarray, threshold: float) -> list[tuple[int, int]]:
    """(detection, truth) pairs of boxes with IoU >= ``threshold``, best IoU first, each used once."""
    if not len(truth) or not len(detected):
        return []
    ious = box_iou(detected, truth)
    candidates = sorted(((-float(ious[d, g]), d, g) for d, g in zip(*np.nonzero(ious >= threshold), strict=True)))
    used_d: set[int] = set()
    used_g: set[int] = set()
    pairs = []
    for _, d, g in candidates:
        if d not in used_d and g not in used_g:
            used_d.add(int(d))
            used_g.add(int(g))
            pairs.append((int(d), int(g)))
    return pairs


def frame_counts(record: FrameRecord, name: str, threshold: float) -> Counts:
    """The counts of one name on one frame."""
    truth = np.array([o.bbox for o in record.truth if o.matches(name)], np.float64).reshape(-1, 4)
    detected = np.array([d[2] for d in record.detected if d[0] == name], np.float64).reshape(-1, 4)
    return Counts(len(truth), len(detected), len(match_greedy(truth, detected, threshold)))


def scored_names(records: Sequence[FrameRecord], names: Sequence[str] | None) -> list[str]:
    """The names the figures are for (see the module doc): given, else detected, else the truth's."""
    if names:
        return list(dict.fromkeys(names))
    detected = sorted({d[0] for r in records for d in r.detected})
    return detected or sorted({o.name for r in records for o in r.truth})


class ImageScorer(Scorer):
    """Feeds on labelled frames and their detections; ``iou`` the F1 match threshold, ``names`` the names
    scored (default: see the module doc), ``worst`` how many worst frames keep their picture."""

    def __init__(self, iou: float = 0.5, names: Sequence[str] | str | None = None, worst: int = 6) -> None:
        if not 0.0 < iou <= 1.0:
            raise ValueError(f"iou {iou} must be in (0, 1]")
        self.iou = float(iou)
        self.names = [names] if isinstance(names, str) else list(names or ())
        self.worst = int(worst)
        self._records: list[FrameRecord] = []
        self._kept: list[tuple[int, int, FrameRecord]] = []  # a min-heap of (badness, -number, record)
        self._seen: set[str] = set()

    def add(self, truth: FrameTruth, detections: DetectedObjectArray, frame: Frame | None = None) -> None:
        objects = tuple(truth.objects)
        for obj in objects:
            if not isinstance(obj, TruthObject2D):
                raise TypeError(f"2D truth objects are TruthObject2D, got {type(obj).__name__} (a 3D label file?)")
        detected: list[Detection] = []
        for obj in detections.objects:
            polygon = tuple((float(x), float(y)) for x, y in obj.polygon.xy())
            detected.append((str(obj.name), polygon, polygon_bbox(polygon)))
        index = truth.index if truth.index is not None else (frame.index if frame is not None else None)
        record = FrameRecord(len(self._records), index, truth.stamp_ns, objects, detected)
        self._records.append(record)
        self._seen.update(d[0] for d in detected)
        if frame is not None and self.worst > 0:
            self._keep(record, frame)

    def _keep(self, record: FrameRecord, frame: Frame) -> None:
        """Keep the frame's picture while it is among the worst so far (by the names known so far)."""
        names = self.names or sorted(self._seen) or sorted({o.name for o in record.truth})
        badness = sum(c.fp + c.fn for c in (frame_counts(record, n, self.iou) for n in names))
        if badness == 0:
            return
        item = (badness, -record.number, record)
        if len(self._kept) < self.worst:
            record.image = np.array(frame.data, copy=True)  # a source may reuse its buffer
            heapq.heappush(self._kept, item)
        elif item[:2] > self._kept[0][:2]:
            record.image = np.array(frame.data, copy=True)
            heapq.heapreplace(self._kept, item)[2].image = None

    def result(self) -> ImageEvaluation:
        return ImageEvaluation(list(self._records), scored_names(self._records, self.names), self.iou,
                               [r for _, _, r in self._kept])


@dataclass
class ImageEvaluation(Evaluation):
    """The 2D figures over the frames scored; see the module doc for what each means."""

    records: list[FrameRecord]
    names: list[str]
    iou: float = 0.5
    kept: list[FrameRecord] = field(default_factory=list)
    kind: str = "2d"

    def __post_init__(self) -> None:
        self.frames = len(self.records)
        self.counts: dict[str, Counts] = {n: Counts() for n in self.names}
        self.frame_counts: list[Counts] = []
        for record in self.records:
            here = Counts()
            for name in self.names:
                counts = frame_counts(record, name, self.iou)
                self.counts[name].add(counts)
                here.add(counts)
            self.frame_counts.append(here)
        self.total = Counts()
        for counts in self.counts.values():
            self.total.add(counts)
        unscored: dict[str, int] = {}
        for record in self.records:
            for obj in record.truth:
                if not any(obj.matches(n) for n in self.names):
                    unscored[obj.name] = unscored.get(obj.name, 0) + 1
        #: Truth objects no scored name matches, by name: left out of every figure.
        self.unscored = dict(sorted(unscored.items()))

    @property
    def score(self) -> float:
        return self.total.f1

    @cached_property
    def coco(self) -> CocoResult:
        """COCO's figures over the scored names (computed when first asked: tuning needs only F1)."""
        images = []
        for record in self.records:
            row = []
            for name in self.names:
                truth = [o for o in record.truth if o.matches(name)]
                row.append(Boxes.of([o.bbox for o in truth], [o.area for o in truth],
                                    [d[2] for d in record.detected if d[0] == name]))
            images.append(row)
        return coco_evaluate(images, len(self.names))

    def coco_stats(self) -> dict[str, float | None]:
        """``COCOeval.stats`` by name (``ap``, ``ap50``, ``ap75``, ``ap_small``..., ``ar1``, ``ar10``, ``ar``...),
        None where COCO gives -1 (nothing defines it)."""
        return {k: _defined(float(v)) for k, v in zip(STAT_NAMES, self.coco.stats, strict=True)}

    def _row(self, name: str, counts: Counts, coco: Mapping[str, float | None]) -> dict[str, Any]:
        return {"name": name, "truth": counts.truth, "detected": counts.detected, "tp": counts.tp, "fp": counts.fp,
                "fn": counts.fn, "precision": counts.precision, "recall": counts.recall, "f1": counts.f1,
                "ap": coco["ap"], "ap50": coco["ap50"], "ap75": coco["ap75"], "ar": coco["ar"]}

    def summary_rows(self) -> list[dict[str, Any]]:
        rows = [self._row(name, self.counts[name], {k: _defined(v) for k, v in self.coco.category(k).items()})
                for k, name in enumerate(self.names)]
        return [*rows, self._row("all", self.total, self.coco_stats())]

    def worst_frames(self) -> list[FrameRecord]:
        """The kept frames with something wrong, worst first (by the final names)."""
        scored = [(self._badness(r), r.number, r) for r in self.kept if r.image is not None]
        return [r for bad, _, r in sorted(scored, key=lambda s: (-s[0], s[1])) if bad > 0]

    def _badness(self, record: FrameRecord) -> int:
        return sum(c.fp + c.fn for c in (frame_counts(record, n, self.iou) for n in self.names))

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind, "frames": self.frames, "score": self.score, "iou": self.iou,
            "names": self.names, "rows": self.summary_rows(), "coco": self.coco_stats(),
            "not_scored": self.unscored,
            "per_frame": [{"index": r.index, "stamp_ns": r.stamp_ns, "truth": c.truth, "detected": c.detected,
                           "tp": c.tp, "fp": c.fp, "fn": c.fn} for r, c in zip(self.records, self.frame_counts,
                                                                               strict=True)],
        }

    def markdown(self) -> str:
        lines = [f"# 2D evaluation: {self.frames} labelled frames", "",
                 f"F1 (the score) **{self.score:.3f}**, precision {_text(self.total.precision)}, recall "
                 f"{_text(self.total.recall)} at IoU {self.iou:g}; COCO AP@[.50:.95] {_text(self.coco_stats()['ap'])}.",
                 "", "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
        for row in self.summary_rows():
            lines.append("| " + " | ".join(_text(row[c]) for c in COLUMNS) + " |")
        lines += ["", "- truth, detected: objects labelled and found; tp: found where labelled (boxes overlapping "
                  f"by IoU >= {self.iou:g}, each used once, best overlap first); fp: found where nothing of that "
                  "name is labelled; fn: labelled and missed.",
                  "- precision = tp / detected, recall = tp / truth, F1 = 2 tp / (2 tp + fp + fn).",
                  "- ap: COCO's average precision over IoU 0.50:0.05:0.95 (pycocotools' figure), ap50 and ap75 at "
                  "one IoU, ar: average recall (100 detections per frame). Detections have no score: each ranks "
                  "in the order found. n/a: nothing to measure (no truth of that name).",
                  "- A detection named like a truth object's group (COCO supercategory) matches it too."]
        if self.unscored:
            left = ", ".join(f"{name} ({count})" for name, count in self.unscored.items())
            lines.append(f"- Not scored (no detection of these names, or of their group): {left}.")
        worst = self.worst_frames()
        lines += ["", "![precision-recall](pr_curve.png)", ""]
        if worst:
            lines.append("Worst frames (truth green, detections red):")
            lines += [f"- {r.name()}: {self._badness(r)} wrong ![{r.name()}]({_worst_name(i)})"
                      for i, r in enumerate(worst, 1)]
        return "\n".join(lines) + "\n"

    def pictures(self, folder: Path) -> list[Path]:
        from .evaluation_pictures import frame_picture, precision_recall_picture, save_png

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        curves = [(name, self.coco.curve(k), self.coco.category(k)["ap50"]) for k, name in enumerate(self.names)]
        written = [save_png(folder / "pr_curve.png", precision_recall_picture(
            curves, f"precision-recall at IoU 0.50, {self.frames} frames (COCO, 101 recall points)"))]
        for i, record in enumerate(self.worst_frames(), 1):
            assert record.image is not None
            counts = Counts()
            for name in self.names:
                counts.add(frame_counts(record, name, self.iou))
            title = (f"{record.name()}: {counts.fp} false positive(s), {counts.fn} missed (green: truth, red: found, "
                     "grey: truth not scored)")
            scored = [o for o in record.truth if any(o.matches(n) for n in self.names)]
            unscored = [o for o in record.truth if o not in scored]
            drawn = frame_picture(record.image, scored, [(d[0], d[1]) for d in record.detected], title, unscored)
            written.append(save_png(folder / _worst_name(i), drawn))
        return written

    def below(self, bars: Mapping[str, float]) -> list[str]:
        values = {"f1": self.total.f1, "precision": self.total.precision, "recall": self.total.recall,
                  "ap": self.coco_stats()["ap"], "ap50": self.coco_stats()["ap50"]}
        missed = []
        for name, bar in bars.items():
            if name not in values:
                raise KeyError(f"no bar {name!r} for 2D figures (bars: {', '.join(BARS)})")
            value = values[name]
            if value is None:
                missed.append(f"{name} n/a < {bar:g} (nothing to measure it on)")
            elif value < bar:
                missed.append(f"{name} {value:.3f} < {bar:g}")
        return missed


def _defined(value: float | None) -> float | None:
    return None if value is None or value <= -1 else value


def _text(value: Any) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


def _worst_name(rank: int) -> str:
    return f"worst_frame_{rank:02d}.png"


__all__ = ["BARS", "Counts", "FrameRecord", "ImageEvaluation", "ImageScorer", "match_greedy"]
