"""Conformance checks for module types, as scikit-learn's ``check_estimator`` is for estimators.

A module's declarations are promises: the hard bounds say what is refused, the soft bounds and choices
what a panel offers, ``get_state`` what a parameter file keeps, the snapshot that a worker thread never sees
half an update. ``check_module(ModuleClass)`` holds one module type to all of them on frames of its kind,
so a third-party plug-in is checked the same way as the built-in modules::

    from objrec_core.testing import check_module

    def test_my_filter():
        check_module(MyFilter)

The first broken promise raises AssertionError naming the module, the check, the parameter and the value.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
import sys
import tempfile
import threading
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from declare.parameters import Bool, Choice, Float, Int, Parameter, ParameterError, Str, short_repr

from .kinds import FrameKindError, Kind
from .messages import Header
from .modules import Detector, Filter, Rect, SelectionRefused
from .observer import Change
from .parametrizable import Parametrizable
from .registry import (
    UnknownModuleError,
    get_kind,
    module_type,
    module_types,
    open_source,
    register_module,
    unregister_module,
)
from .sources import Frame
from .storage import ParameterStorage, build_system
from .system import RecognitionSystem

log = logging.getLogger(__name__)

__all__ = ["CheckReport", "check_all_modules", "check_module"]

#: Frames taken from a kind's demo source when the caller gives none.
DEMO_FRAMES = 2
#: The thread check: reads of ``module.params`` and parameter sets it waits for (it goes on at most
#: ``SNAPSHOT_SECONDS`` plus the time the frames it processes may take).
SNAPSHOT_READS = 20000
SNAPSHOT_READS_DURING = 2000  # of them, read while a set_parameters call was under way
SNAPSHOT_WRITES = 100
SNAPSHOT_SECONDS = 3.0


@dataclass
class CheckReport:
    """What ``check_module`` did, so a test can see that it really processed frames and refused values."""

    module: str
    checks: list[str] = field(default_factory=list)
    check_seconds: dict[str, float] = field(default_factory=dict)
    frames: int = 0  # frames processed
    refused: int = 0  # invalid values refused
    boundaries: int = 0  # boundary values accepted (each processed a frame, unless it is the default)
    rule_refusals: int = 0  # boundary values refused alone by a rule between parameters
    snapshots: int = 0  # snapshots read while another thread set parameters
    seconds: float = 0.0


def check_module(
    module_class: type[Parametrizable],
    *,
    frames: Iterable[Any] | None = None,
    seconds: float = 10.0,
) -> CheckReport:
    """Check everything ``module_class``'s declarations promise; raise AssertionError on the first failure.

    In order: invalid values (past the hard bounds, off the step, of the wrong type, NaN and infinities,
    unknown and unavailable choices) are refused with a ParameterError naming module, parameter and value,
    changing nothing and notifying no one; frames are processed at the defaults and at every boundary value
    (hard and soft bounds, each available choice, both bools), a filter's output being a frame of the kind, a
    detector's a list that makes a JSON line, the input never modified; one value set notifies observers
    once with one Change; ``repr`` shows every value; a parameter file restores every value and the state;
    and a thread reading ``module.params`` while another sets whole value sets never sees half of one.

    ``frames`` (frame data or ``Frame``s of the module's kind) default to a few frames of the kind's demo
    source. ``seconds`` is what one frame may take at the most extreme values the declarations allow; a
    slower frame fails the check, so the whole run stays bounded (each boundary value processes one frame).
    The module type is registered for the parameter-file round trip while the check runs, if it is not.
    """
    if not (isinstance(module_class, type) and issubclass(module_class, Filter | Detector)):
        raise TypeError(f"{module_class!r} is neither a Filter nor a Detector subclass")
    checker = _Checker(module_class, frames, seconds)
    return checker.run()


def check_all_modules(kind: str | None = None, **options: Any) -> dict[str, CheckReport]:
    """``check_module`` on every registered module type (of one kind, where given)."""
    return {name: check_module(klass, **options) for name, klass in module_types(kind).items()}


# -- helpers --------------------------------------------------------------------------------------------
def _same(a: Any, b: Any) -> bool:
    """Equal values of the same type, NaN equal to NaN: a float that comes back as an int is a change."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


def _same_values(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)


def _differences(a: Mapping[str, Any], b: Mapping[str, Any]) -> str:
    names = sorted(set(a) | set(b))
    diffs = [f"{n}: {short_repr(a.get(n, '<missing>'))} -> {short_repr(b.get(n, '<missing>'))}"
             for n in names if n not in a or n not in b or not _same(a[n], b[n])]
    return "; ".join(diffs)


def _as_file_data(value: Any) -> Any:
    """What a value becomes after a trip through YAML (tuples become lists): what a file can keep."""
    return yaml.safe_load(yaml.safe_dump(value, sort_keys=True))


def _snap_to_step(spec: Int, value: int, down: bool) -> int:
    """The nearest value the Int's enforced step allows, towards the inside of its bounds."""
    step = spec.enforced_step
    if step is None:
        return value
    base = spec.min if spec.min is not None else 0
    offset = (value - base) % step
    if not offset:
        return value
    return value - offset if down else value + (step - offset)


def _bad_values(spec: Parameter, default: Any) -> list[tuple[str, Any]]:
    """Values the declaration must refuse, each with what makes it wrong."""
    bad: list[tuple[str, Any]] = []
    if isinstance(spec, Int):
        if spec.min is not None:
            bad.append(("one below the hard minimum", int(spec.min) - 1))
        if spec.max is not None:
            bad.append(("one above the hard maximum", int(spec.max) + 1))
        step = spec.enforced_step
        if step is not None:
            base = int(spec.min) if spec.min is not None else 0
            if spec.max is None or base + 1 <= spec.max:
                bad.append((f"off the step of {step}", base + 1))
        bad += [("text for a number", str(default)), ("a fractional float", float(default) + 0.5),
                ("a whole float", float(default)), ("a bool", True)]
        bad += [("NaN", math.nan), ("+inf", math.inf), ("-inf", -math.inf), ("None", None)]
    elif isinstance(spec, Float):
        if spec.min is not None:
            bad.append(("just below the hard minimum", math.nextafter(float(spec.min), -math.inf)))
        if spec.max is not None:
            bad.append(("just above the hard maximum", math.nextafter(float(spec.max), math.inf)))
        bad += [("text for a number", str(default)), ("a bool", True), ("NaN", math.nan), ("+inf", math.inf),
                ("-inf", -math.inf), ("None", None)]
    elif isinstance(spec, Bool):
        bad += [("1 for a bool", 1), ("0 for a bool", 0), ("text for a bool", "true"), ("None", None)]
    elif isinstance(spec, Choice):
        unknown = "no-such-choice"
        while unknown in spec.choices:
            unknown += "-really"
        bad += [("an unknown choice", unknown), ("a number for a choice", 1), ("None", None)]
        for variant in (default.upper(), default.lower()):
            if variant not in spec.choices:
                bad.append(("a choice in the wrong case", variant))
                break
        bad += [(f"an unavailable choice ({reason})", choice) for choice, reason in spec.unavailable.items()]
    elif isinstance(spec, Str):
        bad += [("a number for text", 1), ("a float for text", 1.5), ("None", None)]
    return bad


def _boundary_values(spec: Parameter, default: Any) -> list[Any]:
    """The values at the edges of what the declaration allows or a panel offers."""
    values: list[Any] = []
    if isinstance(spec, Int):
        for bound, down in ((spec.min, False), (spec.max, True), (spec.soft_min, False), (spec.soft_max, True)):
            if bound is not None:
                values.append(_snap_to_step(spec, int(bound), down))
    elif isinstance(spec, Float):
        values = [float(b) for b in (spec.min, spec.max, spec.soft_min, spec.soft_max) if b is not None]
    elif isinstance(spec, Choice):
        values = list(spec.available_choices)
    elif isinstance(spec, Bool):
        values = [False, True]
    elif isinstance(spec, Str):
        values = ["", default]
    unique: list[Any] = []
    for value in values:
        if not any(_same(value, u) for u in unique):
            unique.append(value)
    return unique


def _alternatives(spec: Parameter, default: Any) -> list[Any]:
    """Valid values other than the default, best first: another choice; for numbers a step from the default
    towards the middle of the slider's range (near the default, so a slow extreme does not make every check
    slow, and a fraction for floats, so the file must keep every digit); then the middle and the bounds."""
    if isinstance(spec, Bool):
        return [not default]
    if isinstance(spec, Choice):
        return [c for c in spec.available_choices if c != default]
    if isinstance(spec, Str):
        return [f"{default}-other" if default else "other"]
    if not isinstance(spec, Int | Float):
        return []
    lo, hi = spec.soft_min, spec.soft_max
    middle = lo + (hi - lo) / 2 if lo is not None and hi is not None else None
    towards = 1 if middle is None or middle >= default else -1
    candidates: list[float] = []
    if isinstance(spec, Int):
        step = spec.enforced_step or 1
        candidates += [default + towards * step, default - towards * step]
    else:
        if middle is not None and middle != default:
            candidates.append(default + (middle - default) / 7)
        candidates += [default + towards / 7, default - towards / 7, default * 8 / 7]
    if middle is not None:
        candidates.append(middle)
    candidates += [b for b in (lo, hi, spec.min, spec.max) if b is not None]
    found: list[Any] = []
    for candidate in candidates:
        if isinstance(spec, Int):
            candidate = _snap_to_step(spec, int(candidate), down=True)
        try:
            value = spec.validate(spec.numeric_type(candidate), "")
        except (ParameterError, OverflowError, ValueError):
            continue
        if not _same(value, default) and not any(_same(value, f) for f in found):
            found.append(value)
    return found


class _Recorder:
    """An observer that keeps every notification."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, tuple[Change, ...]]] = []

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        self.calls.append((subject, tuple(changes)))


_demo_cache: dict[tuple[str, str], list[Any]] = {}
_demo_lock = threading.Lock()


def _demo_frames(kind: str, spec: str) -> list[Any]:
    """A kind's first demo frames, made once per process (a 3D demo frame takes most of a second); callers
    get copies, so a module that writes into its input cannot spoil them for the next check."""
    with _demo_lock:
        if (kind, spec) not in _demo_cache:
            with contextlib.closing(open_source(spec, kind)) as source:
                frames = [f.data for f in itertools.islice(iter(source), DEMO_FRAMES)]
            _demo_cache[kind, spec] = frames
        return _demo_cache[kind, spec]


@contextlib.contextmanager
def _registered(module_class: type[Parametrizable]) -> Iterator[None]:
    """The module type in the registry for the duration (a file names modules by registered type)."""
    name = module_class.type_name
    try:
        previous: type[Parametrizable] | None = module_type(name)
    except UnknownModuleError:
        previous = None
    if previous is module_class:
        yield
        return
    register_module(module_class)
    try:
        yield
    finally:
        unregister_module(name)
        if previous is not None:
            register_module(previous)


@contextlib.contextmanager
def _switch_interval(seconds: float) -> Iterator[None]:
    """Switch threads often, so a half-done update has a real chance of being seen."""
    before = sys.getswitchinterval()
    sys.setswitchinterval(seconds)
    try:
        yield
    finally:
        sys.setswitchinterval(before)


# -- the checker ----------------------------------------------------------------------------------------
class _Checker:
    def __init__(self, module_class: type[Parametrizable], frames: Iterable[Any] | None, seconds: float) -> None:
        self.cls = module_class
        self.seconds = seconds
        self.check = "setup"
        self.name = module_class.type_name
        self.report = CheckReport(self.name)
        self.started = time.perf_counter()
        self.kind = self._kind()
        self.frames = self._frames(frames)
        self.names = [spec.name for spec in module_class.parameter_specs()]
        self.defaults = module_class.default_values()

    # -- failing ------------------------------------------------------------------------------------------
    def fail(self, problem: str, parameter: str | None = None, value: Any = None, *, cause: Any = None) -> None:
        where = f"{self.name} [{self.check}]"
        if parameter is not None:
            where += f" {parameter}={short_repr(value)}"
        raise AssertionError(f"{where}: {problem}") from cause

    def begin(self, check: str) -> None:
        now = time.perf_counter()
        if self.report.checks:
            self.report.check_seconds[self.check] = now - self.started
        self.check, self.started = check, now
        self.report.checks.append(check)

    # -- setup --------------------------------------------------------------------------------------------
    def _kind(self) -> Kind:
        if not self.cls.kind:
            self.fail("the module declares no data kind (set the class attribute kind, e.g. by its kind's base)")
        try:
            return get_kind(self.cls.kind)
        except UnknownModuleError as exc:
            self.fail(f"its kind {self.cls.kind!r} is not registered: {exc}", cause=exc)
            raise  # unreachable: fail raised

    def _frames(self, frames: Iterable[Any] | None) -> list[Any]:
        if frames is None:
            spec = self.kind.demo_spec
            try:
                frames = [self.kind.copy_frame(f) for f in _demo_frames(self.kind.name, spec)]
            except Exception as exc:
                self.fail(f"the {self.kind.name} kind's demo source {spec!r} gave no frames: {exc}", cause=exc)
        data = [f.data if isinstance(f, Frame) else f for f in frames]
        if not data:
            self.fail("no frames to process")
        for index, item in enumerate(data):
            try:
                self.kind.check_frame(item)
            except FrameKindError as exc:
                self.fail(f"frame {index} is not a {self.kind.name} frame: {exc}", cause=exc)
        return data

    def make(self) -> Parametrizable:
        try:
            return self.cls()
        except Exception as exc:
            self.fail(f"cannot be made with its default values: {type(exc).__name__}: {exc}", cause=exc)
            raise  # unreachable

    def run(self) -> CheckReport:
        start = time.perf_counter()
        with _registered(self.cls):
            self.check_declarations()
            self.check_refusals()
            self.check_defaults_process()
            self.check_boundaries()
            self.check_change_events()
            alternative = self.alternative_values()
            self.check_repr(alternative)
            self.check_round_trip(alternative)
            self.check_snapshots(alternative)
            self.begin("done")
        self.report.checks.pop()
        self.report.seconds = time.perf_counter() - start
        log.info("%s passed %d checks: %d frames, %d values refused, %.1f s", self.name,
                 len(self.report.checks), self.report.frames, self.report.refused, self.report.seconds)
        return self.report

    # -- processing one frame -----------------------------------------------------------------------------
    def process(self, module: Parametrizable, data: Any, parameter: str | None = None, value: Any = None) -> Any:
        """One frame in a worker thread, waited for ``seconds`` at most, with every output check."""
        outcome: dict[str, Any] = {}

        def work() -> None:
            try:
                outcome["result"] = self.process_here(module, data, parameter, value)
            except BaseException as exc:  # handed to the checking thread
                outcome["error"] = exc

        worker = threading.Thread(target=work, name=f"check_module {self.name}", daemon=True)
        start = time.perf_counter()
        worker.start()
        worker.join(self.seconds)
        if worker.is_alive():
            self.fail(f"one frame took longer than {self.seconds:g} s (still running)", parameter, value)
        if "error" in outcome:
            raise outcome["error"]
        log.debug("%s: frame in %.3f s", self.name, time.perf_counter() - start)
        return outcome["result"]

    def process_here(self, module: Parametrizable, data: Any, parameter: str | None = None,
                     value: Any = None) -> Any:
        before = self.kind.copy_frame(data)
        try:
            if isinstance(module, Filter):
                result = module.filter(data)
            else:
                assert isinstance(module, Detector)
                result = module.detect(data)
        except Exception as exc:
            self.fail(f"processing a frame raised {type(exc).__name__}: {exc}", parameter, value, cause=exc)
        self.report.frames += 1
        if not self.kind.frames_equal(data, before):
            self.fail("modified its input frame in place (views show it and later modules read it: work on a copy)",
                      parameter, value)
        if isinstance(module, Filter):
            try:
                self.kind.check_frame(result)
            except FrameKindError as exc:
                self.fail(f"its output is not a {self.kind.name} frame: {exc}", parameter, value, cause=exc)
        else:
            if not isinstance(result, list):
                self.fail(f"detect returned {type(result).__name__}, not a list", parameter, value)
            array_type = module.object_array_type  # type: ignore[attr-defined]
            try:
                array = array_type(Header(seq=1, stamp=1.5, frame_id="check"), result)
                line = array.to_json()
                again = array_type.from_json(line)
            except Exception as exc:
                self.fail(f"its objects do not make a JSON line and back: {type(exc).__name__}: {exc}",
                          parameter, value, cause=exc)
            if again.to_dict() != array.to_dict():
                self.fail(f"{array_type.__name__}.from_json does not rebuild its JSON line", parameter, value)
        return result

    # -- the checks ---------------------------------------------------------------------------------------
    def check_declarations(self) -> None:
        self.begin("declarations")
        module = self.make()
        if list(module.get_parameters()) != self.names:
            self.fail(f"get_parameters() names {list(module.get_parameters())}, the declarations {self.names}")
        if not _same_values(module.get_parameters(), self.defaults):
            self.fail(f"a new module's values are not the declared defaults: "
                      f"{_differences(self.defaults, module.get_parameters())}")
        for name in self.names:
            if not _same(getattr(module.params, name), self.defaults[name]):
                self.fail("the snapshot does not hold the default", name, getattr(module.params, name))
        unknown = "no_such_parameter"
        while unknown in self.names:
            unknown += "_really"
        self.expect_refusal(module, unknown, 1, "an undeclared parameter")

    def expect_refusal(self, module: Parametrizable, name: str, value: Any, why: str) -> None:
        """``set_parameters(name=value)`` must raise ParameterError naming all three and change nothing."""
        before = module.get_parameters()
        recorder = _Recorder()
        module.add_observer(recorder)
        try:
            module.set_parameters(**{name: value})
        except ParameterError as exc:
            text = str(exc)
            for what, needle in (("the module", module.label), ("the parameter", name)):
                if needle not in text:
                    self.fail(f"{why} was refused, but the message does not name {what} ({needle!r}): {text!r}",
                              name, value)
            shown = {short_repr(value), repr(value), str(value)}
            if not any(s in text for s in shown):
                self.fail(f"{why} was refused, but the message does not show the value: {text!r}", name, value)
        except Exception as exc:
            self.fail(f"{why} raised {type(exc).__name__} instead of ParameterError: {exc}", name, value, cause=exc)
        else:
            self.fail(f"{why} was accepted (now {short_repr(module.get_parameters().get(name))})", name, value)
        finally:
            module.remove_observer(recorder)
        after = module.get_parameters()
        if not _same_values(before, after):
            self.fail(f"the refusal of {why} changed values: {_differences(before, after)}", name, value)
        if recorder.calls:
            self.fail(f"observers were notified of a refused value ({why})", name, value)
        self.report.refused += 1

    def check_refusals(self) -> None:
        self.begin("refusals")
        module = self.make()
        for spec in self.cls.parameter_specs():
            for why, value in _bad_values(spec, self.defaults[spec.name]):
                self.expect_refusal(module, spec.name, value, why)

    def check_defaults_process(self) -> None:
        self.begin("frames at the defaults")
        module = self.make()
        for data in self.frames:
            self.process(module, data)

    def failing_rules(self, module: Parametrizable, values: Mapping[str, Any]) -> list[Any]:
        failing = []
        for rule in module.parameter_rules():
            try:
                rule.check(values, module.label)
            except ParameterError:
                failing.append(rule)
        return failing

    def check_boundaries(self) -> None:
        self.begin("boundary values")
        module = self.make()
        self.select(module)  # a detector that needs a selection works on it at every boundary value
        for spec in self.cls.parameter_specs():
            name = spec.name
            for value in _boundary_values(spec, self.defaults[name]):
                module.set_parameters(**self.defaults)
                try:
                    module.set_parameters(**{name: value})
                except ParameterError as exc:
                    self.explain_rule_refusal(module, name, value, exc)
                    continue
                except Exception as exc:
                    self.fail(f"a boundary value raised {type(exc).__name__}: {exc}", name, value, cause=exc)
                held = getattr(module.params, name)
                if not _same(held, value):
                    self.fail(f"the boundary value was accepted but the snapshot holds {short_repr(held)}",
                              name, value)
                if not _same(value, self.defaults[name]):  # the defaults' frames were processed already
                    self.process(module, self.frames[0], name, value)
                self.report.boundaries += 1

    def explain_rule_refusal(self, module: Parametrizable, name: str, value: Any, exc: ParameterError) -> None:
        """A boundary value refused alone: only a rule between parameters may do that, and must say which."""
        text = str(exc)
        merged = {**self.defaults, name: value}
        failing = [rule for rule in self.failing_rules(module, merged) if name in rule.names]
        if module.label not in text:
            self.fail(f"a boundary value was refused without naming the module: {text!r}", name, value)
        if failing:
            if not any(all(n in text for n in rule.names) for rule in failing):
                names = " or ".join(str(list(rule.names)) for rule in failing)
                self.fail(f"refused by a rule, but the message does not name its parameters {names}: {text!r}",
                          name, value)
        else:
            others = [n for n in self.names if n != name and n in text]
            if name not in text or not others:
                self.fail("a value within the declared bounds was refused alone, and the message names no other "
                          f"parameter (is a bound wrong, or a rule undeclared?): {text!r}", name, value)
        self.report.rule_refusals += 1

    @staticmethod
    def allowed(module: Parametrizable, values: Mapping[str, Any]) -> bool:
        try:
            module.check_values(values)
        except ParameterError:
            return False
        return True

    def check_change_events(self) -> None:
        self.begin("change events")
        module = self.make()
        recorder = _Recorder()
        module.add_observer(recorder)
        try:
            for spec in self.cls.parameter_specs():
                name, default = spec.name, self.defaults[spec.name]
                allowed = [v for v in _alternatives(spec, default) if self.allowed(module, {**self.defaults, name: v})]
                if not allowed:
                    continue
                new = allowed[0]
                recorder.calls.clear()
                module.set_parameters(**{name: new})
                self.expect_change(module, recorder, name, default, new)
                recorder.calls.clear()
                module.set_parameters(**{name: new})
                if recorder.calls:
                    self.fail(f"setting the value it already has notified observers: {recorder.calls[0][1]}",
                              name, new)
                setattr(module, name, default)  # through the declaration, as ``module.h_min = 3`` does
                self.expect_change(module, recorder, name, new, default)
        finally:
            module.remove_observer(recorder)

    def expect_change(self, module: Parametrizable, recorder: _Recorder, name: str, old: Any, new: Any) -> None:
        if len(recorder.calls) != 1:
            self.fail(f"one value set notified observers {len(recorder.calls)} times, not once", name, new)
        subject, changes = recorder.calls[0]
        if subject is not module:
            self.fail(f"observers were told the subject is {subject!r}, not the module", name, new)
        if len(changes) != 1:
            self.fail(f"one value set carried {len(changes)} changes: {changes}", name, new)
        got = changes[0]
        if got.subject is not module or got.name != name or not _same(got.old, old) or not _same(got.new, new):
            self.fail(f"expected Change({name}, {old!r}, {new!r}), observers got Change({got.name}, {got.old!r}, "
                      f"{got.new!r})", name, new)

    def alternative_values(self) -> dict[str, Any]:
        """A complete valid value set with every parameter off its default where the rules allow: each gets
        another value where one is allowed together with those chosen before it."""
        module = self.make()
        chosen = dict(self.defaults)
        for spec in self.cls.parameter_specs():
            for value in _alternatives(spec, self.defaults[spec.name]):
                trial = {**chosen, spec.name: value}
                try:
                    module.validate_parameters({spec.name: value})
                    module.check_values(trial)
                except ParameterError:
                    continue
                chosen = trial
                break
        return chosen

    def check_repr(self, values: Mapping[str, Any]) -> None:
        self.begin("repr")
        module = self.make()
        for current in (dict(self.defaults), dict(values)):
            module.set_parameters(**current)
            text = repr(module)
            got = module.get_parameters()
            for name, value in got.items():
                if f"{name}={value!r}" not in text:
                    self.fail(f"repr(module) does not show {name}={value!r}: {text}", name, value)
                if not _same(getattr(module.params, name), value):
                    self.fail(f"get_parameters() says {value!r}, the snapshot {getattr(module.params, name)!r}",
                              name, value)

    def select(self, module: Parametrizable) -> None:
        """Give a detector a user's selection (the centre of the first frame's picture, else all of it), so a
        module that keeps state from selections has some to save."""
        if not isinstance(module, Detector):
            return
        data = self.frames[0]
        picture = self.kind.preview(data)
        height, width = picture.shape[:2]
        for rect in (Rect(width // 4, height // 4, max(width // 2, 1), max(height // 2, 1)), Rect(0, 0, width, height)):
            before = self.kind.copy_frame(data)
            try:
                module.process_area_selection(rect, data)
            except SelectionRefused:
                continue
            except Exception as exc:
                self.fail(f"a selection {rect} raised {type(exc).__name__} instead of SelectionRefused: {exc}",
                          cause=exc)
            finally:
                if not self.kind.frames_equal(data, before):
                    self.fail("a selection modified the frame in place")
            return

    def check_round_trip(self, values: Mapping[str, Any]) -> None:
        self.begin("parameter file round trip")
        module = self.make()
        self.select(module)
        self.process(module, self.frames[0])
        try:
            module.set_parameters(**values)
        except ParameterError as exc:
            self.fail(f"a value set its own validation and rules accept was refused: {exc}", cause=exc)
        expected = module.get_parameters()
        state = module.get_state()
        keeps = module.keeps_state()
        if state is not None and not keeps:
            self.fail("get_state() returns state but keeps_state() says the module keeps none")
        system = RecognitionSystem([module], kind=self.kind.name)
        with tempfile.TemporaryDirectory(prefix="check_module-") as folder:
            path = Path(folder) / f"{self.name}.yaml"
            try:
                ParameterStorage(system).save_parameters(path)
                rebuilt_system = build_system(path)
            except Exception as exc:
                self.fail(f"save_parameters/build_system failed: {type(exc).__name__}: {exc}", cause=exc)
            rebuilt = rebuilt_system.modules[0]
            if type(rebuilt) is not self.cls or rebuilt.id != module.id:
                self.fail(f"the file rebuilt {type(rebuilt).__name__} {rebuilt.id!r}, not {self.cls.__name__} "
                          f"{module.id!r}")
            got = rebuilt.get_parameters()
            if not _same_values(expected, got):
                self.fail(f"the file did not restore every value: {_differences(expected, got)}")
            if keeps:
                self.compare_state(state, rebuilt.get_state(), "build_system")
            try:
                ParameterStorage(system).load_parameters(path)
            except Exception as exc:
                self.fail(f"load_parameters into the same module failed: {type(exc).__name__}: {exc}", cause=exc)
            if not _same_values(expected, module.get_parameters()):
                self.fail(f"loading its own file changed values: {_differences(expected, module.get_parameters())}")
            if keeps:
                self.compare_state(state, module.get_state(), "load_parameters")
        self.process(rebuilt, self.frames[0])

    def compare_state(self, before: Any, after: Any, how: str) -> None:
        try:
            saved, restored = _as_file_data(before), _as_file_data(after)
        except yaml.YAMLError as exc:
            self.fail(f"get_state() is not YAML-safe data: {exc}", cause=exc)
        if saved != restored:
            self.fail(f"the state did not survive the file ({how}): saved {short_repr(saved)}, "
                      f"got back {short_repr(restored)}")

    def check_snapshots(self, values: Mapping[str, Any]) -> None:
        """One thread alternates two complete value sets while another reads snapshots and processes
        frames: every snapshot must be one set or the other, field for field."""
        self.begin("snapshots across threads")
        first, second = dict(self.defaults), dict(values)
        if _same_values(first, second):
            return
        module = self.make()
        allowed = [tuple(first[n] for n in self.names), tuple(second[n] for n in self.names)]
        done, busy = threading.Event(), threading.Event()
        writes = [0]
        errors: list[BaseException] = []
        seen_bad: list[tuple[Any, ...]] = []

        def writer() -> None:
            try:
                while not done.is_set():
                    for value_set in (second, first):
                        busy.set()
                        module.set_parameters(**value_set)
                        busy.clear()
                        writes[0] += 1
            except BaseException as exc:
                errors.append(exc)

        def reader() -> None:
            try:
                deadline = time.perf_counter() + SNAPSHOT_SECONDS + self.seconds * len(self.frames)
                reads = during = processed = 0
                while time.perf_counter() < deadline:
                    writing = busy.is_set()
                    snapshot = module.params
                    got = tuple(getattr(snapshot, n) for n in self.names)
                    if not any(all(_same(g, a) for g, a in zip(got, want, strict=True)) for want in allowed):
                        seen_bad.append(got)
                        return
                    reads += 1
                    during += writing
                    if reads % 1000 == 0 and processed < len(self.frames):
                        self.process_here(module, self.frames[processed])
                        processed += 1
                    if (reads >= SNAPSHOT_READS and during >= SNAPSHOT_READS_DURING and writes[0] >= SNAPSHOT_WRITES
                            and processed == len(self.frames)):
                        break
                self.report.snapshots = reads
            except BaseException as exc:
                errors.append(exc)

        threads = [threading.Thread(target=writer, daemon=True), threading.Thread(target=reader, daemon=True)]
        with _switch_interval(1e-5):
            for thread in threads:
                thread.start()
            threads[1].join(SNAPSHOT_SECONDS + self.seconds * (len(self.frames) + 1))
            done.set()
            threads[0].join(self.seconds + SNAPSHOT_SECONDS)
        if any(t.is_alive() for t in threads):
            self.fail("setting parameters while another thread reads them did not finish in time")
        if errors:
            error = errors[0]
            if isinstance(error, AssertionError):
                raise error
            self.fail(f"raised {type(error).__name__} while another thread set parameters: {error}", cause=error)
        if seen_bad:
            mixed = dict(zip(self.names, seen_bad[0], strict=True))
            parts = [f"{n}={short_repr(v)} ({'first' if _same(v, first[n]) else 'second'} set)"
                     for n, v in mixed.items() if not _same(first[n], second[n])]
            self.fail("a snapshot read while another thread set parameters mixes the two value sets: "
                      + ", ".join(parts))
        if writes[0] < 2:
            self.fail("no value set was applied while the snapshots were read")
