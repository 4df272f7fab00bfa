"""Conformance checks for source types: what ``FrameSource``'s contract promises, held to one opened spec.

``length`` agrees with the frames yielded, ``frames_from(i)`` starts at the i-th frame of a full iteration
(where ``seekable``), ``close`` may be called twice, declared options are refused outside their range with a
message naming the option, and frames are frames of the kind, numbered in order, with sane stamps and rate.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

from declare.parameters import short_repr

from ..kinds import FrameKindError, Kind
from ..registry import UnknownModuleError, get_kind, open_source
from ..sources import Frame, FrameSource, SourceError
from .cases import Case, Deviations, declared_deviations, run_declared
from .limits import call_with_cpu_limit
from .support import NamedChecks

log = logging.getLogger(__name__)

#: The source checks, in the order ``check_source`` runs them (their ids in cases and expected_failures).
SOURCE_CHECKS = ("frames", "length", "seek", "close", "options", "rate-stamp")
#: Frames read of a source whose length is unknown (a camera, an endless scene).
SAMPLE_FRAMES = 3


@dataclass
class SourceReport:
    """What ``check_source`` did: the checks run, frames read, out-of-range options refused, positions sought,
    and the declared deviations."""

    source: str
    checks: list[str] = field(default_factory=list)
    frames: int = 0
    refused: int = 0
    seeks: int = 0
    deviations: Deviations = field(default_factory=Deviations)


class _SourceChecker(NamedChecks):
    def __init__(self, source: type[FrameSource] | str, spec: str | None, kind: str | None, max_frames: int,
                 seconds: float) -> None:
        self.check = "setup"
        if isinstance(source, str):
            self.cls: type[FrameSource] | None = None
            self.spec = source
        elif isinstance(source, type) and issubclass(source, FrameSource):
            self.cls = source
            if spec is None and not source.schemes:
                raise TypeError(f"{source.__name__} has no scheme: give spec= naming something it reads")
            self.spec = spec if spec is not None else source.schemes[0]
        else:
            raise TypeError(f"{source!r} is neither a FrameSource subclass nor a source spec")
        self.kind_name = kind if kind is not None else (self.cls.kind if self.cls is not None else None)
        self.max_frames = max_frames
        self.seconds = seconds
        self.name = self.cls.__name__ if self.cls is not None else self.spec
        self.report = SourceReport(self.name)

    # -- failing ------------------------------------------------------------------------------------------
    def fail(self, problem: str, *, cause: BaseException | None = None) -> None:
        raise AssertionError(f"{self.name} [{self.check}] {self.spec!r}: {problem}") from cause

    # -- opening and reading ------------------------------------------------------------------------------
    def open(self) -> FrameSource:
        try:
            source = open_source(self.spec, self.kind_name)
        except SourceError as exc:
            self.fail(f"cannot be opened: {exc}", cause=exc)
            raise  # unreachable
        if self.cls is not None and not isinstance(source, self.cls):
            source.close()
            self.fail(f"the spec opens a {type(source).__name__}, not a {self.cls.__name__}")
        if self.cls is None:
            self.cls = type(source)
        return source

    @property
    def kind(self) -> Kind:
        name = self.kind_name or (self.cls.kind if self.cls is not None else None)
        if not name:
            self.fail("the source type declares no data kind (set the class attribute kind)")
        try:
            return get_kind(str(name))
        except UnknownModuleError as exc:
            self.fail(f"its kind {name!r} is not registered: {exc}", cause=exc)
            raise  # unreachable

    def read(self, frames: Iterator[Frame], count: int | None, what: str) -> list[Frame]:
        """Up to ``count`` frames (all where None), read within the CPU limit per frame."""
        got: list[Frame] = []
        while count is None or len(got) < count:
            if len(got) > self.max_frames:
                self.fail(f"{what} gave more than max_frames={self.max_frames} frames (an endless source with a "
                          "length?)")
            try:
                frame, _ = call_with_cpu_limit(lambda: next(frames, None), self.seconds, name=f"check_source {what}")
            except AssertionError as exc:
                self.fail(f"reading frame {len(got)} of {what}: {exc}", cause=exc)
            except Exception as exc:
                self.fail(f"reading frame {len(got)} of {what} raised {type(exc).__name__}: {exc}", cause=exc)
            if frame is None:
                break
            got.append(frame)
        self.report.frames += len(got)
        return got

    def all_frames(self, source: FrameSource) -> list[Frame]:
        length = source.length
        return self.read(iter(source), None if length is not None else SAMPLE_FRAMES, "a full iteration")

    # -- the checks ---------------------------------------------------------------------------------------
    def check_frames(self) -> None:
        kind = self.kind
        with contextlib.closing(self.open()) as source:
            frames = self.all_frames(source)
        if not frames:
            self.fail("yielded no frame (a source that has none should refuse to open, naming the reason)")
        for number, frame in enumerate(frames):
            if not isinstance(frame, Frame):
                self.fail(f"item {number} is a {type(frame).__name__}, not a Frame")
            try:
                kind.check_frame(frame.data)
            except FrameKindError as exc:
                self.fail(f"frame {number}'s data is not a {kind.name} frame: {exc}", cause=exc)
            if frame.index != number:
                self.fail(f"frame {number} of a full iteration is numbered {frame.index!r}")

    def check_length(self) -> None:
        with contextlib.closing(self.open()) as source:
            length = source.length
            if length is None:
                with contextlib.suppress(TypeError):
                    self.fail(f"length is None but len(source) gives {len(source)} (it must raise TypeError)")
                return
            if not isinstance(length, int) or isinstance(length, bool) or length < 0:
                self.fail(f"length is {short_repr(length)}, not None or a count")
            if length > self.max_frames:
                self.fail(f"length {length} is more than max_frames={self.max_frames}: check a shorter spec")
            if len(source) != length:
                self.fail(f"len(source) is {len(source)} but length is {length}")
            frames = self.all_frames(source)
        if len(frames) != length:
            self.fail(f"length says {length} frames, a full iteration yielded {len(frames)}")

    def check_seek(self) -> None:
        kind = self.kind
        with contextlib.closing(self.open()) as source:
            if not source.seekable:
                try:
                    next(iter(source.frames_from(0)), None)
                except SourceError:
                    return
                self.fail("seekable is False but frames_from(0) did not raise SourceError")
            frames = self.all_frames(source)
            length = source.length if source.length is not None else len(frames)
            positions = sorted({0, 1, len(frames) // 2, len(frames) - 1} & set(range(len(frames))))
            for index in positions:
                got = self.read(iter(source.frames_from(index)), 2, f"frames_from({index})")
                expected = frames[index:index + 2]
                if [f.index for f in got] != [f.index for f in expected]:
                    self.fail(f"frames_from({index}) yields frames numbered {[f.index for f in got]}, a full "
                              f"iteration {[f.index for f in expected]}")
                for want, have in zip(expected, got, strict=True):
                    if not kind.frames_equal(want.data, have.data):
                        self.fail(f"frames_from({index}) yields other data for frame {want.index} than a full "
                                  "iteration")
                self.report.seeks += 1
            past = self.read(iter(source.frames_from(length)), 1, f"frames_from({length}) (past the end)")
            if past:
                self.fail(f"frames_from({length}), past the end of {length} frames, yields frame {past[0].index}")

    def check_close(self) -> None:
        source = self.open()
        with source:
            self.read(iter(source), 1, "the first frame")
        for attempt in ("a second", "a third"):
            try:
                source.close()
            except Exception as exc:
                self.fail(f"{attempt} close() raised {type(exc).__name__}: {exc} (close must be idempotent)",
                          cause=exc)
        unused = self.open()
        unused.close()
        unused.close()

    def option_examples(self) -> list[tuple[str, str, str]]:
        """(option, text, why) for each declared option's invalid texts, as its type writes them into a spec
        (any parameter type, a plug-in's included)."""
        assert self.cls is not None
        return [(name, text, why) for name, option in self.cls.options.items()
                for why, text in option.invalid_texts()]

    def check_options(self) -> None:
        if self.cls is None:
            self.open().close()
        assert self.cls is not None
        if not self.cls.schemes:
            return  # options come only with a scheme
        scheme = self.cls.schemes[0]
        for name, text, why in self.option_examples():
            spec = f"{scheme}:{name}={text}"
            try:
                source = open_source(spec, self.kind_name or self.cls.kind)
            except SourceError as exc:
                message = str(exc)
                if name not in message or text not in message:
                    self.fail(f"{spec} ({why}) was refused, but the message does not name the option and value: "
                              f"{message!r}")
                self.report.refused += 1
                continue
            except Exception as exc:
                self.fail(f"{spec} ({why}) raised {type(exc).__name__} instead of SourceError: {exc}", cause=exc)
            source.close()
            self.fail(f"{spec} ({why}) was accepted")

    def check_rate_stamp(self) -> None:
        with contextlib.closing(self.open()) as source:
            rate = source.rate
            frames = self.all_frames(source)
        if rate is not None and (isinstance(rate, bool) or not isinstance(rate, int | float) or not math.isfinite(rate)
                                 or rate <= 0):
            self.fail(f"rate is {short_repr(rate)}, not None or a positive number of frames per second")
        stamps = [f.stamp for f in frames]
        for number, stamp in enumerate(stamps):
            if isinstance(stamp, bool) or not isinstance(stamp, int | float) or not math.isfinite(stamp) or stamp < 0:
                self.fail(f"frame {number}'s stamp is {short_repr(stamp)}, not a finite time in seconds")
        for number, (before, after) in enumerate(itertools.pairwise(stamps), 1):
            if after < before:
                self.fail(f"frame {number}'s stamp {after!r} is earlier than frame {number - 1}'s {before!r}")


def check_source(
    source: type[FrameSource] | str,
    *,
    spec: str | None = None,
    kind: str | None = None,
    max_frames: int = 200,
    seconds: float = 10.0,
    expected_failures: Mapping[str, str] | None = None,
) -> SourceReport:
    """Check what a source type promises, on one spec it opens; AssertionError on the first broken promise.

    ``source`` is a ``FrameSource`` subclass (opened with ``spec``, by default its first scheme alone) or a
    spec (checked as whichever type opens it, for ``kind``). The spec should name something short: a source
    of known length is read whole, at most ``max_frames`` frames; an endless one for its first few. Reading
    one frame may take ``seconds`` of CPU time. ``expected_failures`` (and the class attribute of that name)
    declares checks the source cannot pass, with the reason: they are recorded in the report's
    ``deviations``, as are declared checks that pass anyway (logged as a warning).
    """
    checker = _SourceChecker(source, spec, kind, max_frames, seconds)
    declared = declared_deviations(checker.cls or object, expected_failures, SOURCE_CHECKS)
    for check in SOURCE_CHECKS:
        run_declared(f"{checker.name}::{check}", checker.runner(check), declared.get(check),
                     checker.report.deviations)
    log.info("%s passed the source checks: %d frames, %d options refused", checker.name, checker.report.frames,
             checker.report.refused)
    return checker.report


def source_cases(
    source: type[FrameSource] | str,
    *,
    spec: str | None = None,
    kind: str | None = None,
    max_frames: int = 200,
    seconds: float = 10.0,
    expected_failures: Mapping[str, str] | None = None,
    id: str | None = None,
) -> list[Case]:
    """``check_source``'s checks as separate cases, ids ``NAME::CHECK`` (NAME: ``id``, else the class name or
    the spec). Each case opens its own source when run."""
    probe = _SourceChecker(source, spec, kind, max_frames, seconds)
    declared = declared_deviations(probe.cls or object, expected_failures, SOURCE_CHECKS)
    label = id or probe.name

    def case(check: str) -> Case:
        def run() -> None:
            _SourceChecker(source, spec, kind, max_frames, seconds).runner(check)()

        return Case(f"{label}::{check}", run, declared.get(check))

    return [case(check) for check in SOURCE_CHECKS]
