"""Directors pipe frames from a source through a recognition system.

``DefinitionDirector`` hands every stage to a view (the GUI implements ``StageView``);
``DetectionDirector`` hands each detected-object array to sinks. Neither knows any GUI type.
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
from .sources import Frame
from .system import PipelineError, RecognitionSystem, Stage

log = logging.getLogger(__name__)

Sink = Callable[[DetectedObjectArray], None]


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
        self.frame_id = frame_id
        self._seq = 0

    # The seed's wiring methods, for building a system step by step.
    def add_filter(self, module: Filter) -> None:
        detectors = [i for i, m in enumerate(self.system.modules) if isinstance(m, Detector)]
        self.system.add_module(module, detectors[0] if detectors else None)

    def set_detector(self, detector: Detector) -> None:
        """Replace every detector with this one (the seed's systems had exactly one)."""
        self.system.set_modules([m for m in self.system.modules if not isinstance(m, Detector)] + [detector])

    def _header(self, frame: Frame) -> Header:
        header = Header(seq=self._seq, stamp=frame.stamp, frame_id=self.frame_id)
        self._seq += 1
        return header

    def _check_runnable(self) -> None:
        if not self.system.detectors:
            raise PipelineError("the pipeline has no detector")

    @staticmethod
    def _frames(
        source: Iterable[Any], max_frames: int | None, stop: threading.Event | None
    ) -> Iterator[Frame]:
        """Frames until ``max_frames`` or ``stop``, never pulling one more than is processed: a camera asked
        for one frame too many could fail after the work was done."""
        if max_frames is not None:
            source = itertools.islice(source, max_frames)
        for index, item in enumerate(source):
            yield item if isinstance(item, Frame) else Frame(item, index=index)
            if stop is not None and stop.is_set():
                return


class DetectionDirector(_Director):
    """Runs a system headless and hands each frame's detected objects to sinks."""

    def __init__(self, system: RecognitionSystem | None = None, *, sinks: Iterable[Sink] = (), **kwargs: Any):
        super().__init__(system, **kwargs)
        self.sinks: list[Sink] = list(sinks)

    def add_sink(self, sink: Sink) -> None:
        self.sinks.append(sink)

    def process(self, frame: Frame | Any) -> DetectedObjectArray:
        if not isinstance(frame, Frame):
            frame = Frame(frame, index=self._seq)
        result = self.system.process(frame.data)
        array = self.system.object_array_type(self._header(frame), result.objects)
        for sink in self.sinks:
            sink(array)
        return array

    def process_with_stages(self, frame: Frame | Any) -> tuple[DetectedObjectArray, list[Stage]]:
        """Like ``process``, keeping every stage (for writing debug views headless); slower."""
        if not isinstance(frame, Frame):
            frame = Frame(frame, index=self._seq)
        result = self.system.process(frame.data, keep_stages=True)
        array = self.system.object_array_type(self._header(frame), result.objects)
        for sink in self.sinks:
            sink(array)
        return array, result.stages or []

    def run(
        self, source: Iterable[Any], max_frames: int | None = None, stop: threading.Event | None = None
    ) -> Iterator[DetectedObjectArray]:
        """Process frames until the source ends, ``max_frames`` are done or ``stop`` is set."""
        self._check_runnable()
        if stop is not None and stop.is_set():
            return
        for frame in self._frames(source, max_frames, stop):
            yield self.process(frame)


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
