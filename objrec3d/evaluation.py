"""Scoring 3D detections against truth shapes: what ``objrec-eval`` and ``objrec-tune`` report for point clouds.

Per frame, detections are matched one-to-one to the truth shapes by centre distance (:mod:`.evaluation_match`:
a pair counts when the centres lie within ``max(match_distance, match_share x radius)`` metres, 5 cm and half
the radius by default). Over all frames, per object name and in all:

- **precision, recall, F1**: a match whose names agree is a true positive; a detection matched to nothing, or
  to a truth of another name, is a false positive; a truth shape left unmatched (or matched by a detection of
  another name) is a miss. With nothing to find and nothing found, all three are 1.
- **recall against visible points**: a truth shape that fewer than ``min_visible`` points of the frame show
  (counted in the frame's cloud: points within ``visible_tolerance`` of the solid; or the label file's
  ``visible_points`` where no cloud is given) is *hidden*: like COCO's ignored truths, missing it is no miss
  and a detection matched to it is neither right nor wrong. The ``hidden`` column says how many there were.
- **errors of the true positives**: centre error (metres), radius error (detected - true, metres; spheres
  and cylinders), axis angle error (degrees, 0..90; cylinders), each as median, 90th percentile and maximum.
- **shape-type confusion**: true shape (rows, plus "nothing" for detections matched to no truth) against the
  detected shape (columns, plus "missed"), over every matched pair whatever the names.
- **tracking**, when the detections carry ``id`` (the ShapeDetector's tracker): identity switches and IDF1
  (:mod:`.tracking_score`).

The score tuning maximises is F1 over all names: it rewards finding each shape and nothing else, and does not
move with how precisely the centre is fitted (the error figures say that, and ``centre_error_p90`` is a bar).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import DetectedObjectArray, Frame
from objrec_core.evaluation import Evaluation, FrameTruth, Scorer

from .cloud import PointCloud
from .evaluation_match import Gate, axis_angle_deg, match_frame, visible_counts
from .messages import DetectedObject3D
from .tracking_score import TrackingFigures, TrackingScore
from .truth import SHAPES, TruthShape, as_truth_shape

#: Rows of the confusion matrix: the true shapes, then detections with no truth.
CONFUSION_ROWS = (*SHAPES, "nothing")
#: Columns: the detected shapes, a detection of no such shape ("other": a plane, a box of another detector),
#: then truth shapes no detection matched.
CONFUSION_COLUMNS = (*SHAPES, "other", "missed")
#: Bars a user can set, and whether a figure must reach them (min) or stay under them (max).
BARS = {"f1": "min", "precision": "min", "recall": "min", "idf1": "min",
        "centre_error_p90": "max", "radius_error_p90": "max", "axis_error_p90": "max"}
#: Error figures and their units.
ERRORS = {"centre_error": "m", "radius_error": "m", "axis_error": "deg"}
#: How many of the worst frames are kept for pictures.
WORST_FRAMES = 4


def distribution(values: list[float]) -> dict[str, Any]:
    """Median, 90th percentile and maximum of the absolute values (None where there are none), and the count."""
    if not values:
        return {"n": 0, "median": None, "p90": None, "max": None}
    a = np.abs(np.asarray(values, dtype=float))
    return {"n": int(a.size), "median": float(np.median(a)), "p90": float(np.percentile(a, 90)),
            "max": float(a.max())}


def ratio(num: int, den: int) -> float:
    return num / den if den else 1.0


@dataclass
class NameCounts:
    """The counts and errors of one object name (or of all)."""

    truth: int = 0
    detected: int = 0
    tp: int = 0
    fp: int = 0
    fn: int = 0
    hidden: int = 0
    errors: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in ERRORS})

    @property
    def precision(self) -> float:
        return ratio(self.tp, self.tp + self.fp)

    @property
    def recall(self) -> float:
        return ratio(self.tp, self.tp + self.fn)

    @property
    def f1(self) -> float:
        return ratio(2 * self.tp, 2 * self.tp + self.fp + self.fn)

    def to_dict(self) -> dict[str, Any]:
        data: dict[str, Any] = {"truth": self.truth, "detected": self.detected, "tp": self.tp, "fp": self.fp,
                                "fn": self.fn, "hidden": self.hidden, "precision": self.precision,
                                "recall": self.recall, "f1": self.f1}
        for name, unit in ERRORS.items():
            data[name] = {"unit": unit, **distribution(self.errors[name])}
        return data


@dataclass(order=True)
class WorstFrame:
    """A frame kept for a picture: its misses plus false detections, and what was on it."""

    errors: int
    order: int
    frame: Any = field(compare=False)
    truth: FrameTruth = field(compare=False)
    detections: tuple[DetectedObject3D, ...] = field(compare=False)


class ShapeEvaluation(Evaluation):
    """The figures of a :class:`ShapeScorer` (see the module's docstring)."""

    kind = "3d"

    def __init__(self, names: dict[str, NameCounts], confusion: np.ndarray, tracking: TrackingFigures | None,
                 frames: int, options: dict[str, Any], worst: list[WorstFrame]) -> None:
        self.names = names
        self.all = NameCounts()
        for counts in names.values():
            for attr in ("truth", "detected", "tp", "fp", "fn", "hidden"):
                setattr(self.all, attr, getattr(self.all, attr) + getattr(counts, attr))
            for key in ERRORS:
                self.all.errors[key].extend(counts.errors[key])
        self.confusion = confusion
        self.tracking = tracking
        self.frames = frames
        self.options = options
        self.worst = sorted(worst, reverse=True)

    @property
    def score(self) -> float:
        """F1 over all names."""
        return self.all.f1

    def figure(self, name: str) -> float | None:
        """One figure of the "all" row by its bar name (``f1``, ``centre_error_p90``, ``idf1``, ...)."""
        if name in ("f1", "precision", "recall"):
            return float(getattr(self.all, name))
        if name == "idf1":
            return None if self.tracking is None else self.tracking.idf1
        error, _, stat = name.rpartition("_")
        return distribution(self.all.errors[error])[stat]

    def _row(self, name: str, counts: NameCounts) -> dict[str, Any]:
        row: dict[str, Any] = {"name": name, "truth": counts.truth, "detected": counts.detected, "tp": counts.tp,
                               "fp": counts.fp, "fn": counts.fn, "hidden": counts.hidden,
                               "precision": counts.precision, "recall": counts.recall, "f1": counts.f1}
        for error in ERRORS:
            stats = distribution(counts.errors[error])
            row[f"{error}_median"], row[f"{error}_p90"] = stats["median"], stats["p90"]
        if self.tracking is not None:
            whole = name == "all"
            row["idf1"] = self.tracking.idf1 if whole else None
            row["id_switches"] = self.tracking.id_switches if whole else None
        return row

    def summary_rows(self) -> list[dict[str, Any]]:
        """One row per name and "all": counts, P/R/F1, median and p90 of each error; with tracking, the "all"
        row's IDF1 and identity switches (None in the per-name rows)."""
        return [self._row(n, c) for n, c in sorted(self.names.items())] + [self._row("all", self.all)]

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind, "frames": self.frames, "score": self.score, "score_is": "f1", "options": self.options,
            "names": {n: c.to_dict() for n, c in sorted(self.names.items())}, "all": self.all.to_dict(),
            "confusion": {"rows": list(CONFUSION_ROWS), "columns": list(CONFUSION_COLUMNS),
                          "counts": self.confusion.astype(int).tolist()},
            "tracking": None if self.tracking is None else self.tracking.to_dict(),
            "worst_frames": [{"index": w.truth.index, "stamp_ns": w.truth.stamp_ns, "misses_and_false": w.errors}
                             for w in self.worst],
        }

    def markdown(self) -> str:
        from .evaluation_report import markdown

        return markdown(self)

    def pictures(self, folder: Path) -> list[Path]:
        from .evaluation_pictures import write_pictures

        return write_pictures(self, Path(folder))

    def below(self, bars: Mapping[str, float]) -> list[str]:
        """The bars missed: ``f1``, ``precision``, ``recall``, ``idf1`` are minimums; ``centre_error_p90``,
        ``radius_error_p90`` (metres) and ``axis_error_p90`` (degrees) maximums. A figure that cannot be
        measured (no true positive to take an error of; no tracking ids for ``idf1``) misses its bar."""
        missed = []
        for name, bar in bars.items():
            if name not in BARS:
                raise KeyError(f"{name!r} is no 3D bar (known: {', '.join(BARS)})")
            value = self.figure(name)
            if value is None:
                missed.append(f"{name} not measured (no {'tracking ids' if name == 'idf1' else 'true positive'})"
                              f" {'<' if BARS[name] == 'min' else '>'} {bar:g}")
            elif BARS[name] == "min" and value < bar:
                missed.append(f"{name} {value:.4g} < {bar:g}")
            elif BARS[name] == "max" and value > bar:
                missed.append(f"{name} {value:.4g} > {bar:g}")
        return missed


class ShapeScorer(Scorer):
    """Scores 3D detections against truth shapes frame by frame.

    Options: ``match_distance`` (metres, default 0.05) and ``match_share`` (of the truth's radius, default 0.5)
    make the gate; ``min_visible`` (points, default 50) and ``visible_tolerance`` (metres, default 0.01) decide
    which truth shapes are hidden. An unknown option is a TypeError naming it.
    """

    def __init__(self, match_distance: float = 0.05, match_share: float = 0.5, min_visible: int = 50,
                 visible_tolerance: float = 0.01) -> None:
        self.gate = Gate(float(match_distance), float(match_share))
        if not (int(min_visible) == min_visible and min_visible >= 0):
            raise ValueError(f"min_visible={min_visible!r} must be a whole number of points, 0 or more")
        if not (visible_tolerance >= 0 and math.isfinite(visible_tolerance)):
            raise ValueError(f"visible_tolerance={visible_tolerance!r} must be 0 or more metres")
        self.min_visible = int(min_visible)
        self.visible_tolerance = float(visible_tolerance)
        self._names: dict[str, NameCounts] = {}
        self._confusion = np.zeros((len(CONFUSION_ROWS), len(CONFUSION_COLUMNS)), dtype=np.int64)
        self._tracking = TrackingScore()
        self._tracked = False
        self._frames = 0
        self._worst: list[WorstFrame] = []
        self._order = itertools.count()

    def _counts(self, name: str) -> NameCounts:
        return self._names.setdefault(name, NameCounts())

    def _hidden(self, truths: list[TruthShape], frame: Frame | None) -> list[bool]:
        """Which truth shapes too few points show."""
        if self.min_visible == 0:
            return [False] * len(truths)
        cloud = getattr(frame, "data", None)
        if isinstance(cloud, PointCloud):
            seen: list[int | None] = list(visible_counts(cloud.points, truths, self.visible_tolerance))
        else:
            seen = [shape.visible_points for shape in truths]
        return [n is not None and n < self.min_visible for n in seen]

    def add(self, truth: FrameTruth, detections: DetectedObjectArray, frame: Frame | None = None) -> None:
        truths = [as_truth_shape(o) for o in truth.objects]
        found: list[DetectedObject3D] = [o if isinstance(o, DetectedObject3D) else DetectedObject3D.from_dict(o)
                                         for o in detections.objects]
        hidden = self._hidden(truths, frame)
        match = match_frame(truths, found, self.gate)
        self._frames += 1
        for i, shape in enumerate(truths):
            counts = self._counts(shape.name)
            counts.hidden += hidden[i]
            counts.truth += not hidden[i]
        ignored: set[int] = set()  # detections matched to hidden truths: neither right nor wrong
        errors = 0
        for i, j, distance in match.pairs:
            shape, obj = truths[i], found[j]
            if hidden[i]:
                ignored.add(j)
                continue
            self._confusion[CONFUSION_ROWS.index(shape.shape), _column(obj)] += 1
            if shape.name != obj.name:
                self._counts(shape.name).fn += 1
                self._counts(obj.name).fp += 1
                self._counts(obj.name).detected += 1
                errors += 2
                continue
            counts = self._counts(shape.name)
            counts.tp += 1
            counts.detected += 1
            counts.errors["centre_error"].append(distance)
            if shape.radius > 0 and obj.radius > 0:
                counts.errors["radius_error"].append(obj.radius - shape.radius)
            if shape.shape == "cylinder" and shape.axis is not None and obj.shape == "cylinder":
                counts.errors["axis_error"].append(axis_angle_deg(shape.axis, obj.axis))
        for i in match.lone_truths:
            if not hidden[i]:
                self._counts(truths[i].name).fn += 1
                self._confusion[CONFUSION_ROWS.index(truths[i].shape), CONFUSION_COLUMNS.index("missed")] += 1
                errors += 1
        for j in match.lone_detections:
            self._counts(found[j].name).fp += 1
            self._counts(found[j].name).detected += 1
            self._confusion[CONFUSION_ROWS.index("nothing"), _column(found[j])] += 1
            errors += 1
        tracked = [(o.id, tuple(o.center)) for j, o in enumerate(found) if o.id and j not in ignored]
        if tracked:
            self._tracked = True
        self._tracking.add([(s.identity, s.centre, self.gate.of(s)) for i, s in enumerate(truths) if not hidden[i]],
                           [(ident, (c[0], c[1], c[2])) for ident, c in tracked])
        if errors and frame is not None:
            entry = WorstFrame(errors, -next(self._order), frame, truth, tuple(found))
            if len(self._worst) < WORST_FRAMES:
                heapq.heappush(self._worst, entry)
            else:
                heapq.heappushpop(self._worst, entry)

    def result(self) -> ShapeEvaluation:
        options = {"match_distance": self.gate.distance, "match_share": self.gate.share,
                   "min_visible": self.min_visible, "visible_tolerance": self.visible_tolerance}
        names = {n: _copy(c) for n, c in self._names.items()}
        tracking = self._tracking.figures() if self._tracked else None
        return ShapeEvaluation(names, self._confusion.copy(), tracking, self._frames, options, list(self._worst))


def _column(obj: DetectedObject3D) -> int:
    return CONFUSION_COLUMNS.index(obj.shape if obj.shape in SHAPES else "other")


def _copy(counts: NameCounts) -> NameCounts:
    return NameCounts(counts.truth, counts.detected, counts.tp, counts.fp, counts.fn, counts.hidden,
                      {k: list(v) for k, v in counts.errors.items()})
