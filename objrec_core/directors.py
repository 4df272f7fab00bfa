"""Directors pipe frames from a source through a recognition system.

``DetectionDirector`` owns the headless run loop: frames until the source ends, ``max_frames`` or a stop
request; progress; sinks for the detected-object arrays; annotation sinks that also receive the frame (and
every stage, when asked for); outcome sinks that hear what each detector made of each frame (how many
objects, or its reason for none). ``DefinitionDirector`` hands every stage to a view (the GUI implements
``StageView``). Neither knows any GUI type or data kind.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from .messages import DetectedObjectArray, Header
from .modules import Detector, Filter, Rect, SelectionRefused
from .sources import Frame, FrameSource
from .system import PipelineError, RecognitionSystem, Stage

log = logging.getLogger(__name__)

#: Receives each frame's detected objects.
Sink = Callable[[DetectedObjectArray], None]


@dataclass(frozen=True)
class DetectorOutcome:
    """What one detector made of one frame: how many objects it found and, when none, the reason its result
    carried (None where the detector gives no reasons)."""

    detector: str  # the detector's id
    type_name: str
    found: int
    reason: str | None = None


#: Receives each frame's header and one outcome per detector, in pipeline order.
OutcomeSink = Callable[[Header, Sequence[DetectorOutcome]], None]


class AnnotationSink(Protocol):
    """Receives each frame with its objects and, when the director keeps them, every stage."""

    def __call__(self, frame: Frame, objects: DetectedObjectArray, stages: Sequence[Stage] | None) -> None: ...


class Progress(Protocol):
    """What the run loop reports progress to (a progress bar in the apps)."""

    def start(self, total: int | None) -> None: ...

    def advance(self, frames: int = 1) -> None: ...

    def close(self) -> None: ...


@dataclass
class RunStats:
    """What a run did: frames processed, objects found, seconds spent, and why it stopped."""

    frames: int = 0
    objects: int = 0
    frames_with_objects: int = 0
    seconds: float = 0.0
    stopped_by: str = ""

    @property
    def rate(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0


@dataclass
class StageResults:
    """Everything a definition view shows for one frame."""

    frame: Frame
    stages: list[Stage]
    objects: DetectedObjectArray
    seconds: float  # processing time of the pipeline


class StageView(Protocol):
    """What a DefinitionDirector draws on. Called from the thread that runs the director."""

    def show_stages(self, results: StageResults) -> None: ...


@dataclass
class SelectionResult:
    """Which detectors took a selection and which refused it, with their reasons."""

    accepted: list[str] = field(default_factory=list)
    refused: dict[str, str] = field(default_factory=dict)


class _Director:
    def __init__(
        self,
        system: RecognitionSystem | None = None,
        *,
        filters: Sequence[Filter] = (),
        detector: Detector | None = None,
        object_name: str = "object",
        frame_id: str = "camera",
    ) -> None:
        if system is None:
            modules = [*filters, *([detector] if detector is not None else [])]
            system = RecognitionSystem(modules, object_name=object_name)
        elif filters or detector is not None:
            raise TypeError("give either a system or filters and a detector, not both")
        self.system = system
        #: The frame_id of headers for frames whose source gives none.
        self.frame_id = frame_id
        self._seq = 0

    def add_filter(self, module: Filter) -> None:
        """Add a filter before the first detector (building a system step by step)."""
        detectors = [i for i, m in enumerate(self.system.modules) if isinstance(m, Detector)]
        self.system.add_module(module, detectors[0] if detectors else None)

    def set_detector(self, detector: Detector) -> None:
        """Replace every detector with this one."""
        self.system.set_modules([m for m in self.system.modules if not isinstance(m, Detector)] + [detector])

    def _header(self, frame: Frame) -> Header:
        header = Header.fast(self._seq, frame.stamp, frame.frame_id or self.frame_id, frame.stamp_ns)
        self._seq += 1
        return header

    def _check_runnable(self) -> None:
        if not self.system.detectors:
            raise PipelineError("the pipeline has no detector")

    @staticmethod
    def _frames(source: Iterable[Any], max_frames: int | None, stop: threading.Event | None) -> Iterator[Frame]:
        """Frames until ``max_frames`` or ``stop``, never pulling one more than is processed: a camera asked
        for one frame too many could fail after the work was done."""
        if stop is not None and isinstance(source, FrameSource):
            source.watch_stop(stop)  # a live source waiting for its next frame ends that wait on a stop
        if max_frames is not None:
            source = itertools.islice(source, max_frames)
        for index, item in enumerate(source):
            yield item if isinstance(item, Frame) else Frame(item, index=index)
            if stop is not None and stop.is_set():
                return


class DetectionDirector(_Director):
    """Runs a system headless and hands each frame's detected objects to sinks.

    ``annotation_sinks`` also get the frame (for pictures); with ``keep_stages`` they get every stage too
    (a debug view), at the cost of keeping them.
    """

    def __init__(
        self,
        system: RecognitionSystem | None = None,
        *,
        sinks: Iterable[Sink] = (),
        annotation_sinks: Iterable[AnnotationSink] = (),
        outcome_sinks: Iterable[OutcomeSink] = (),
        keep_stages: bool = False,
        **kwargs: Any,
    ):
        super().__init__(system, **kwargs)
        self.sinks: list[Sink] = list(sinks)
        self.annotation_sinks: list[AnnotationSink] = list(annotation_sinks)
        self.outcome_sinks: list[OutcomeSink] = list(outcome_sinks)
        self.keep_stages = keep_stages
        #: What the last (or current) ``run`` did.
        self.stats = RunStats()

    def add_sink(self, sink: Sink) -> None:
        self.sinks.append(sink)

    def add_annotation_sink(self, sink: AnnotationSink) -> None:
        self.annotation_sinks.append(sink)

    def add_outcome_sink(self, sink: OutcomeSink) -> None:
        self.outcome_sinks.append(sink)

    def not_ready(self) -> list[str]:
        """Why detectors cannot detect, one line each ("pipeline[0] (poster): FeatureDetector cannot detect:
        no target ..."), from their ``ready``; empty when all can. A headless run checks this before it opens
        its source; the GUI does not, since that is where a user makes a detector ready."""
        return [
            f"pipeline[{index}] ({module.id}): {module.type_name} cannot detect: {why}"
            for index, module in enumerate(self.system.modules)
            if isinstance(module, Detector) and (why := module.ready()) is not None
        ]

    def process(self, frame: Frame | Any) -> DetectedObjectArray:
        """One frame through the pipeline and every sink."""
        if not isinstance(frame, Frame):
            frame = Frame(frame, index=self._seq)
        system = self.system
        if self.keep_stages or self.outcome_sinks:
            result = system.process(frame.data, self.keep_stages)
            objects, stages, array_type = result.objects, result.stages, system.object_array_type
        else:  # nothing asks for stages or reasons: the objects alone, with no record made to be thrown away
            plan = system.plan  # taken once: the modules run and the message type belong together
            result, objects, stages, array_type = None, plan.detect_objects(frame.data), None, plan.array_type
        array = array_type(self._header(frame), objects)
        for sink in self.sinks:
            sink(array)
        for annotation_sink in self.annotation_sinks:
            annotation_sink(frame, array, stages)
        if result is not None and self.outcome_sinks:
            outcomes = [DetectorOutcome(d.id, d.type_name, n, None if n else result.reasons.get(d.id))
                        for d, n in result.found]
            for outcome_sink in self.outcome_sinks:
                outcome_sink(array.header, outcomes)
        return array

    def run(
        self,
        source: Iterable[Any],
        max_frames: int | None = None,
        stop: threading.Event | None = None,
        progress: Progress | None = None,
    ) -> Iterator[DetectedObjectArray]:
        """Process frames until the source ends, ``max_frames`` are done or ``stop`` is set; ``stats`` counts
        them as they go. Progress hears the total where the source knows its length."""
        self._check_runnable()
        self.stats = stats = RunStats()
        if stop is not None and stop.is_set():
            stats.stopped_by = "stop"
            return
        total = getattr(source, "length", None)
        if max_frames is not None:
            total = max_frames if total is None else min(total, max_frames)
        start = time.perf_counter()
        if progress is not None:
            progress.start(total)
        try:
            for frame in self._frames(source, max_frames, stop):
                array = self.process(frame)
                stats.frames += 1
                stats.objects += len(array.objects)
                stats.frames_with_objects += bool(array.objects)
                stats.seconds = time.perf_counter() - start
                if progress is not None:
                    progress.advance()
                yield array
            if stop is not None and stop.is_set():
                stats.stopped_by = "stop"
            elif max_frames is not None and stats.frames >= max_frames:
                stats.stopped_by = "max_frames"
            else:
                stats.stopped_by = "end"
        finally:
            stats.seconds = time.perf_counter() - start
            if progress is not None:
                progress.close()

    def run_all(self, source: Iterable[Any], max_frames: int | None = None,
                stop: threading.Event | None = None, progress: Progress | None = None) -> RunStats:
        """``run`` to the end, for callers that only want the sinks' output and the counts."""
        for _ in self.run(source, max_frames, stop, progress):
            pass
        return self.stats


class DefinitionDirector(_Director):
    """Runs a system for a person tuning it: every stage goes to the view, and area selections reach
    the detectors as the frame they saw."""

    def __init__(self, system: RecognitionSystem | None = None, *, view: StageView | None = None, **kwargs: Any):
        super().__init__(system, **kwargs)
        self.view = view
        self._last_inputs: dict[str, Any] = {}
        self._last_frame: Frame | None = None

    def set_view(self, view: StageView) -> None:
        self.view = view

    def process(self, frame: Frame | Any) -> StageResults:
        if not isinstance(frame, Frame):
            frame = Frame(frame, index=self._seq)
        start = time.perf_counter()
        result = self.system.process(frame.data, keep_stages=True)
        seconds = time.perf_counter() - start
        self._last_frame, self._last_inputs = frame, result.detector_inputs
        array = self.system.object_array_type(self._header(frame), result.objects)
        results = StageResults(frame, result.stages or [], array, seconds)
        if self.view is not None:
            self.view.show_stages(results)
        return results

    def run(
        self, source: Iterable[Any], max_frames: int | None = None, stop: threading.Event | None = None
    ) -> Iterator[StageResults]:
        if stop is not None and stop.is_set():
            return
        for frame in self._frames(source, max_frames, stop):
            yield self.process(frame)

    @property
    def last_frame(self) -> Frame | None:
        return self._last_frame

    def process_area_selection(
        self, rect: Rect, frame: Any | None = None, results: StageResults | None = None
    ) -> SelectionResult:
        """Give a selection to every detector with the frame it saw: in ``results`` (the frame a person drew
        on, which a view may show after newer ones were processed), else in the last frame processed; or
        ``frame`` itself, where given."""
        outcome = SelectionResult()
        if results is not None:
            inputs = {s.id: s.output for s in results.stages if s.role == "detector"}
            missing = "it was not in the pipeline when this frame was processed"
        else:
            inputs, missing = self._last_inputs, "no frame has been processed yet"
        for detector in self.system.detectors:
            seen = frame if frame is not None else inputs.get(detector.id)
            if seen is None:
                outcome.refused[detector.id] = missing
                continue
            try:
                detector.process_area_selection(rect, seen)
            except SelectionRefused as exc:
                outcome.refused[detector.id] = str(exc)
            else:
                outcome.accepted.append(detector.id)
        return outcome
