"""objrec-detect's outputs beside the detections: pictures (``--annotate``), a Rerun recording (``--rerun``)
and the reasons a detector found nothing (``--explain``).

Each keeps what it got when another output fails; one that cannot be opened is a one-line UserError.
"""

from __future__ import annotations

from collections.abc import Sequence

from objrec_core import DetectedObjectArray, DetectionDirector, Frame, Kind, RecognitionSystem, Stage
from rerunio import RerunUnavailable
from strictio import OutputError

from . import explain
from .annotation_writer import AnnotationError, AnnotationWriter
from .cli import UserError
from .output_contract import Output, RunEnd
from .rerun_log import open_rerun


class PictureSink:
    """Writes each frame's picture: the kind's annotation, or with ``debug`` the first detector's own view."""

    def __init__(self, writer: AnnotationWriter, kind: Kind, debug: bool) -> None:
        self.writer, self.kind, self.debug = writer, kind, debug

    def __call__(self, frame: Frame, objects: DetectedObjectArray, stages: Sequence[Stage] | None) -> None:
        picture = None
        if self.debug and stages:
            picture = next((s.debug for s in stages if s.debug is not None), None)
            if isinstance(picture, dict):
                picture = next(iter(picture.values()), None)
        self.writer.write(picture if picture is not None else self.kind.annotate(frame, objects))


class Pictures(Output):
    """``--annotate``: a video or a folder of PNGs, each frame annotated (or the detector's debug view)."""

    option = "--annotate"
    named_errors = (OutputError, AnnotationError)

    def __init__(self, path: str, kind: Kind, debug: bool = False) -> None:
        super().__init__(path)
        try:
            self.writer = AnnotationWriter(path)
        except AnnotationError as exc:
            raise UserError(str(exc)) from None
        self._sink = PictureSink(self.writer, kind, debug)

    def attach(self, director: DetectionDirector) -> None:
        director.keep_stages = director.keep_stages or self._sink.debug
        director.add_annotation_sink(self._sink)

    def close(self, end: RunEnd) -> None:
        self.writer.close()

    def summary(self) -> str:
        return f"{self.writer.count} annotated frames written to {self.path}"


class RerunRecording(Output):
    """``--rerun``: every frame, stage and detection logged to a ``.rrd`` file or a spawned viewer."""

    option = "--rerun"

    def __init__(self, target: str, kind: Kind, system: RecognitionSystem) -> None:
        super().__init__(target)
        try:
            self.recorder = open_rerun(target, kind, system)
        except RerunUnavailable as exc:
            raise UserError(str(exc)) from None

    def attach(self, director: DetectionDirector) -> None:
        director.keep_stages = True
        director.add_annotation_sink(self.recorder)

    def close(self, end: RunEnd) -> None:
        self.recorder.close()


class Reasons(Output):
    """``--explain``: why a detector found nothing, as text on stderr or JSON Lines in a side file."""

    option = explain.OPTION
    named_errors = (OutputError, explain.ExplainWriteError)

    def __init__(self, target: str) -> None:
        super().__init__(None if target == explain.STDERR else target)
        self.explainer = explain.Explainer(target)
        self.uses_stderr = self.explainer.to_stderr

    def attach(self, director: DetectionDirector) -> None:
        director.add_outcome_sink(self.explainer.sink)

    def close(self, end: RunEnd) -> None:
        self.explainer.close()
