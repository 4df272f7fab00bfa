"""Conformance checks for data kinds: what the ``Kind`` contract promises, on the kind's demo frames.

``check_frame`` accepts frames and refuses other things with FrameKindError (``is_frame`` agreeing);
``preview`` and ``annotate`` give BGR ``uint8`` H x W x 3 pictures and leave the frame alone; ``copy_frame``
gives an equal, independent copy and ``frames_equal`` tells frames apart; ``outlines`` describes the objects
of the kind's own detectors in the documented shapes (``points`` too, for kinds with ``has_points``).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..kinds import FrameKindError, Kind, Outline
from ..messages import Header
from ..modules import Detector, Filter
from ..registry import get_kind, module_types
from ..sources import Frame
from .cases import Case, Deviations, declared_deviations, run_declared
from .demo_frames import demo_frames
from .limits import call_with_cpu_limit
from .support import NamedChecks

log = logging.getLogger(__name__)

#: The kind checks, in the order ``check_kind`` runs them (their ids in cases and expected_failures).
KIND_CHECKS = ("check-frame", "preview", "annotate", "copy-frame", "outlines")
#: Things no kind takes as a frame.
NOT_FRAMES: tuple[tuple[str, Any], ...] = (("None", None), ("text", "a frame"), ("an object", object()),
                                           ("a dict", {"data": 1}))


@dataclass
class KindReport:
    """What ``check_kind`` did: the checks run, frames looked at, outlines checked, declared deviations."""

    kind: str
    checks: list[str] = field(default_factory=list)
    frames: int = 0
    outlines: int = 0
    deviations: Deviations = field(default_factory=Deviations)


def _is_picture(value: Any) -> bool:
    return isinstance(value, np.ndarray) and value.dtype == np.uint8 and value.ndim == 3 and value.shape[2] == 3 \
        and value.shape[0] > 0 and value.shape[1] > 0


class _KindChecker(NamedChecks):
    def __init__(self, kind: Kind | type[Kind] | str, frames: Iterable[Any] | None, seconds: float) -> None:
        if isinstance(kind, str):
            kind = get_kind(kind)
        elif isinstance(kind, type):
            kind = kind()
        if not isinstance(kind, Kind):
            raise TypeError(f"{kind!r} is not a Kind")
        self.kind = kind
        self.check = "setup"
        self.seconds = seconds
        self.given = None if frames is None else [f.data if isinstance(f, Frame) else f for f in frames]
        self.report = KindReport(kind.name)

    def fail(self, problem: str, *, cause: BaseException | None = None) -> None:
        raise AssertionError(f"kind {self.kind.name!r} [{self.check}]: {problem}") from cause

    def frames(self) -> list[Any]:
        if self.given is not None:
            frames = [self.kind.copy_frame(f) for f in self.given]
        else:
            try:
                frames = demo_frames(self.kind.name)
            except Exception as exc:
                self.fail(f"its demo source {self.kind.demo_spec!r} gave no frames: {exc}", cause=exc)
        if not frames:
            self.fail("no frames to check")
        self.report.frames += len(frames)
        return frames

    def call(self, what: str, work: Callable[[], Any]) -> Any:
        try:
            return call_with_cpu_limit(work, self.seconds, name=f"check_kind {what}")[0]
        except AssertionError as exc:
            self.fail(f"{what}: {exc}", cause=exc)
        except Exception as exc:
            self.fail(f"{what} raised {type(exc).__name__}: {exc}", cause=exc)

    # -- the checks ---------------------------------------------------------------------------------------
    def check_check_frame(self) -> None:
        for number, data in enumerate(self.frames()):
            try:
                self.kind.check_frame(data)
            except FrameKindError as exc:
                self.fail(f"check_frame refuses demo frame {number}: {exc}", cause=exc)
            if self.kind.is_frame(data) is not True:
                self.fail(f"is_frame is not True for demo frame {number}")
        for what, thing in NOT_FRAMES:
            try:
                self.kind.check_frame(thing)
            except FrameKindError as exc:
                if not str(exc):
                    self.fail(f"check_frame refused {what} with an empty message (say what the data is)")
            except Exception as exc:
                self.fail(f"check_frame raised {type(exc).__name__} for {what}, not FrameKindError: {exc}",
                          cause=exc)
            else:
                self.fail(f"check_frame accepted {what}")
            if self.kind.is_frame(thing) is not False:
                self.fail(f"is_frame is not False for {what}")

    def check_preview(self) -> None:
        for number, data in enumerate(self.frames()):
            before = self.kind.copy_frame(data)
            picture = self.call(f"preview(frame {number})", lambda data=data: self.kind.preview(data))
            if not _is_picture(picture):
                self.fail(f"preview(frame {number}) is {_describe(picture)}, not a BGR uint8 H x W x 3 picture")
            if not self.kind.frames_equal(data, before):
                self.fail(f"preview modified frame {number}")
            if self.kind.has_points:
                points = self.call(f"points(frame {number})", lambda data=data: self.kind.points(data))
                if not (isinstance(points, np.ndarray) and points.ndim == 2 and points.shape[1] == 3
                        and np.issubdtype(points.dtype, np.floating)):
                    self.fail(f"has_points, but points(frame {number}) is {_describe(points)}, not N x 3 floats")

    def check_annotate(self) -> None:
        array_type = self.kind.object_array_type
        for number, data in enumerate(self.frames()):
            before = self.kind.copy_frame(data)
            frame = Frame(data, 1.5, number, "check_kind", frame_id="check")
            for objects in self.detections(data):
                array = array_type(Header(seq=number, stamp=1.5, frame_id="check"), objects)
                picture = self.call(f"annotate(frame {number}, {len(objects)} objects)",
                                    lambda frame=frame, array=array: self.kind.annotate(frame, array))
                if not _is_picture(picture):
                    self.fail(f"annotate(frame {number}) is {_describe(picture)}, not a BGR uint8 H x W x 3 picture")
                if not self.kind.frames_equal(data, before):
                    self.fail(f"annotate drew into frame {number} itself (draw on a copy)")

    def check_copy_frame(self) -> None:
        frames = self.frames()
        for number, data in enumerate(frames):
            copy = self.kind.copy_frame(data)
            if copy is data:
                self.fail(f"copy_frame(frame {number}) returned the frame itself")
            if not self.kind.frames_equal(data, copy) or not self.kind.frames_equal(copy, data):
                self.fail(f"frames_equal says frame {number} differs from its copy")
            if not self.kind.frames_equal(data, data):
                self.fail(f"frames_equal says frame {number} differs from itself (NaN must equal NaN)")
        for first, second in itertools.pairwise(frames):
            if self.kind.frames_equal(first, second) != self.kind.frames_equal(second, first):
                self.fail("frames_equal(a, b) and frames_equal(b, a) disagree")

    def detections(self, data: Any) -> list[list[Any]]:
        """No objects, and what each of the kind's registered detectors finds at its defaults in the frame and
        in each registered filter's output (a colour detector needs a mask): objects of the kind's own types."""
        types = module_types(self.kind.name).values()
        inputs = [data]
        for klass in (t for t in types if issubclass(t, Filter)):
            with contextlib.suppress(Exception):  # a module's own failures are check_module's business
                inputs.append(call_with_cpu_limit(lambda k=klass: k().filter(self.kind.copy_frame(data)),
                                                  self.seconds)[0])
        found: list[list[Any]] = [[]]
        for klass in (t for t in types if issubclass(t, Detector)):
            for given in inputs:
                with contextlib.suppress(Exception):
                    objects = list(call_with_cpu_limit(lambda k=klass, g=given: k().detect(g), self.seconds)[0])
                    if objects:
                        found.append(objects)
                        break
        return found

    def check_outlines(self) -> None:
        array_type = self.kind.object_array_type
        for number, data in enumerate(self.frames()):
            for objects in self.detections(data):
                array = array_type(Header(seq=number, stamp=1.5, frame_id="check"), objects)
                outlines = self.call("outlines", lambda array=array: self.kind.outlines(array))
                if not isinstance(outlines, list) or len(outlines) > len(objects):
                    self.fail(f"outlines of {len(objects)} objects is {_describe(outlines)}, not a list of at most "
                              "one Outline per object")
                for outline in outlines:
                    self.check_outline(outline)
                    self.report.outlines += 1

    def check_outline(self, outline: Any) -> None:
        if not isinstance(outline, Outline) or not isinstance(outline.label, str):
            self.fail(f"an outline is {outline!r}, not an Outline with a text label")
        polygon, box = outline.polygon, outline.box
        if polygon is not None:
            polygon = np.asarray(polygon)
            if polygon.ndim != 2 or polygon.shape[1] != 2 or polygon.shape[0] == 0 or not np.isfinite(polygon).all():
                self.fail(f"outline {outline.label!r}: polygon is {_describe(polygon)}, not N x 2 finite pixels")
        if box is not None:
            box = np.asarray(box, dtype=float)
            if box.shape != (8, 3) or not np.isfinite(box).all():
                self.fail(f"outline {outline.label!r}: box is {_describe(box)}, not 8 x 3 finite corners")
            self.check_box_corners(outline.label, box)

    def check_box_corners(self, label: str, box: np.ndarray) -> None:
        """Corner i at -/+ half a side along local x, y, z by bits 2, 1, 0: opposite corners share a centre
        and the edges along one axis are parallel and equal."""
        centre = box.mean(axis=0)
        for i in range(8):
            if not np.allclose(box[i] + box[7 - i], 2 * centre, atol=1e-6 * max(1.0, float(np.abs(box).max()))):
                self.fail(f"outline {label!r}: box corners {i} and {7 - i} are not opposite each other")
        for bit in (4, 2, 1):
            edges = [box[i | bit] - box[i] for i in range(8) if not i & bit]
            if not all(np.allclose(edge, edges[0], atol=1e-6 * max(1.0, float(np.abs(box).max()))) for edge in edges):
                self.fail(f"outline {label!r}: box edges along bit {bit} of the corner index are not parallel and "
                          "equal (corner order)")


def _describe(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"a {value.dtype} array of shape {value.shape}"
    return f"a {type(value).__name__}"


def check_kind(
    kind: Kind | type[Kind] | str,
    *,
    frames: Iterable[Any] | None = None,
    seconds: float = 10.0,
    expected_failures: Mapping[str, str] | None = None,
) -> KindReport:
    """Check what a data kind promises; AssertionError on the first broken promise. ``kind`` is a Kind, its
    class or its registered name; ``frames`` (data or Frames) default to the first of its demo source.
    ``seconds`` is the CPU time one preview, annotation or detection may take. ``expected_failures`` (and the
    kind's class attribute of that name) declares checks it cannot pass, with the reason."""
    checker = _KindChecker(kind, frames, seconds)
    declared = declared_deviations(checker.kind, expected_failures, KIND_CHECKS)
    for check in KIND_CHECKS:
        run_declared(f"{checker.kind.name}::{check}", checker.runner(check), declared.get(check),
                     checker.report.deviations)
    log.info("kind %s passed the kind checks: %d frames, %d outlines", checker.kind.name, checker.report.frames,
             checker.report.outlines)
    return checker.report


def kind_cases(
    kind: Kind | type[Kind] | str,
    *,
    frames: Iterable[Any] | None = None,
    seconds: float = 10.0,
    expected_failures: Mapping[str, str] | None = None,
) -> list[Case]:
    """``check_kind``'s checks as separate cases, ids ``kind-NAME::CHECK``."""
    frames = None if frames is None else list(frames)
    probe = _KindChecker(kind, frames, seconds)
    declared = declared_deviations(probe.kind, expected_failures, KIND_CHECKS)

    def case(check: str) -> Case:
        return Case(f"kind-{probe.kind.name}::{check}",
                    lambda: _KindChecker(probe.kind, frames, seconds).runner(check)(), declared.get(check))

    return [case(check) for check in KIND_CHECKS]
