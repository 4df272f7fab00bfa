"""Running a system over the labelled frames of a source and scoring it: what objrec-eval, objrec-tune and
the GUI's quality strip all do, so they agree on every figure.

Only labelled frames are processed. Where the truth is keyed by index and the source can seek
(``FrameSource.seekable``: folders, videos, bags, cloud files), each labelled frame is read directly; a source
that cannot seek (a demo, a live topic) is read through and its labelled frames kept. Frames can also be read
once and kept (:func:`load_labelled`) so that a tuning search scores hundreds of parameter sets on the same
frames without reading them again.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

from ..directors import DetectionDirector
from ..kinds import Kind
from ..messages import DetectedObjectArray
from ..sources import Frame, FrameSource, SourceError
from ..system import RecognitionSystem
from .scoring import Evaluation
from .truth import FrameTruth, TruthSet

#: One labelled frame: the frame and its truth.
Labelled = tuple[Frame, FrameTruth]


def labelled_frames(source: FrameSource | Iterable[Frame], truth: TruthSet,
                    stop: threading.Event | None = None) -> Iterator[Labelled]:
    """The frames of ``source`` that ``truth`` labels, in source order, each with its truth.

    A truth set with no frame found in the source is a SourceError naming both (the wrong file for this
    source, or a stamp-keyed set over a source whose frames have no stamps)."""
    found = 0
    seekable = isinstance(source, FrameSource) and source.seekable and truth.keyed_by == "index"
    if seekable:
        assert isinstance(source, FrameSource)
        for index in truth.indices:
            if stop is not None and stop.is_set():
                return
            frame = next(iter(source.frames_from(index)), None)
            if frame is None:
                continue
            label = truth.lookup(frame.index, frame.stamp_ns)
            if label is not None:
                found += 1
                yield frame, label
    else:
        wanted = len(truth)
        for frame in source:
            if stop is not None and stop.is_set():
                return
            label = truth.lookup(frame.index, frame.stamp_ns)
            if label is not None:
                found += 1
                yield frame, label
                if found == wanted:
                    break
    if not found and len(truth):
        name = getattr(source, "name", "the source")
        raise SourceError(f"{truth.path or 'the truth'}: none of its {len(truth)} labelled frames is in {name} "
                          f"(keyed by {truth.keyed_by})")


def load_labelled(source: FrameSource | Iterable[Frame], truth: TruthSet,
                  stop: threading.Event | None = None) -> list[Labelled]:
    """Every labelled frame read once, kept in memory (for a search that scores many parameter sets)."""
    return list(labelled_frames(source, truth, stop))


def score(system: RecognitionSystem, kind: Kind, frames: Iterable[Labelled], *,
          stop: threading.Event | None = None, on_frame: Callable[[Frame, DetectedObjectArray], None] | None = None,
          **scorer_options: Any) -> Evaluation:
    """Run ``system`` on each labelled frame and score what it detects; ``on_frame`` sees each result."""
    director = DetectionDirector(system)
    scorer = kind.scorer(**scorer_options)
    for frame, label in frames:
        if stop is not None and stop.is_set():
            break
        objects = director.process(frame)
        scorer.add(label, objects, frame)
        if on_frame is not None:
            on_frame(frame, objects)
    return scorer.result()


def saved_pairs(detections: Iterable[DetectedObjectArray], truth: TruthSet
                ) -> Iterator[tuple[FrameTruth, DetectedObjectArray]]:
    """Detections saved earlier (JSON Lines, a bag) paired with their truth: by header stamp where the set is keyed
    by stamp, else by order (the n-th array is frame n, as objrec-detect writes one line per frame)."""
    for index, array in enumerate(detections):
        label = truth.lookup(index, array.header.stamp_ns)
        if label is not None:
            yield label, array


def score_saved(kind: Kind, detections: Iterable[DetectedObjectArray], truth: TruthSet,
                **scorer_options: Any) -> Evaluation:
    """Score detections saved earlier, each paired with its truth by :func:`saved_pairs`."""
    scorer = kind.scorer(**scorer_options)
    for label, array in saved_pairs(detections, truth):
        scorer.add(label, array, None)
    return scorer.result()


def split(frames: Sequence[Labelled], held_out: float, seed: int) -> tuple[list[Labelled], list[Labelled]]:
    """Searched and held-out frames: every frame goes to one side, a fixed share held out, the same for the same
    seed; at least one frame on each side when there are two or more."""
    import random

    order = list(range(len(frames)))
    random.Random(seed).shuffle(order)
    n_out = round(len(frames) * held_out)
    if len(frames) >= 2:
        n_out = min(max(n_out, 1), len(frames) - 1)
    out = set(order[:n_out])
    return ([f for i, f in enumerate(frames) if i not in out], [f for i, f in enumerate(frames) if i in out])
