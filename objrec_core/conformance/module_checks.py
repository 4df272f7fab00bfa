"""Conformance checks for module types, as scikit-learn's ``check_estimator`` is for estimators.

A module's declarations are promises: the hard bounds say what is refused, the soft bounds and choices
what a panel offers, ``get_state`` what a parameter file keeps, the snapshot that a worker thread never sees
half an update. ``check_module(ModuleClass)`` holds one module type to all of them on frames of its kind,
so a third-party plug-in is checked the same way as the built-in modules. Each check also runs alone, as
one case (``module_cases``), and a module may declare a check it cannot pass (``expected_failures``).
The first broken promise raises AssertionError naming the module, the check, the parameter and the value.
"""

from __future__ import annotations

import logging
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from declare.parameters import ParameterError, short_repr

from ..kinds import FrameKindError, Kind
from ..messages import Header
from ..modules import Detector, Filter, Rect, SelectionRefused
from ..parametrizable import Parametrizable
from ..registry import (
    UnknownModuleError,
    get_kind,
    module_types,
)
from ..sources import Frame
from ..storage import ParameterStorage, build_system
from ..system import RecognitionSystem
from .cases import Case, Deviations, declared_deviations, run_declared
from .demo_frames import demo_frames
from .limits import CPULimitExceeded, call_with_cpu_limit
from .module_space_checks import check_search_space
from .support import Recorder, as_file_data, differences, registered, same, same_values, switch_interval

log = logging.getLogger(__name__)

#: The module checks in the order they run: (id in cases and expected_failures, title in messages and reports).
MODULE_CHECKS: tuple[tuple[str, str], ...] = (
    ("declarations", "declarations"),
    ("refusals", "refusals"),
    ("defaults", "frames at the defaults"),
    ("boundaries", "boundary values"),
    ("change-events", "change events"),
    ("repr", "repr"),
    ("round-trip", "parameter file round trip"),
    ("snapshots", "snapshots across threads"),
    ("search-space", "search space"),
)
MODULE_CHECK_IDS = tuple(check_id for check_id, _ in MODULE_CHECKS)
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
    seconds: float = 0.0  # wall-clock, for the log only
    frame_cpu_seconds: float = 0.0  # the most CPU time one frame took in the worker
    deviations: Deviations = field(default_factory=Deviations)


def check_module(
    module_class: type[Parametrizable],
    *,
    frames: Iterable[Any] | None = None,
    seconds: float = 10.0,
    expected_failures: Mapping[str, str] | None = None,
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
    source. ``seconds`` is the CPU time one frame may take at the most extreme values the declarations allow
    (CPU, not wall-clock, time: a busy machine does not fail a healthy module, nor an idle one pass a slow
    one); a slower frame fails the check, so the whole run stays bounded (each boundary value processes one
    frame). Wall-clock time only guards against a frame that hangs (minutes). The module type is registered
    for the parameter-file round trip while the check runs, if it is not.

    ``expected_failures`` (and the class attribute of that name) maps check ids (``MODULE_CHECK_IDS``) to the
    reason the module cannot pass them; such a failure is recorded in the report's ``deviations``, and a
    declared check that passes anyway is recorded there too and logged as a warning.
    """
    _check_class(module_class)
    checker = _Checker(module_class, frames, seconds)
    declared = declared_deviations(module_class, expected_failures, MODULE_CHECK_IDS)
    return checker.run(declared=declared)


def module_cases(
    module_class: type[Parametrizable],
    *,
    frames: Iterable[Any] | None = None,
    seconds: float = 10.0,
    expected_failures: Mapping[str, str] | None = None,
) -> list[Case]:
    """``check_module``'s checks as separate cases, ids ``TypeName::CHECK``; each makes its own modules (and
    reads the demo frames, made once per process) when run."""
    _check_class(module_class)
    frames = None if frames is None else list(frames)
    declared = declared_deviations(module_class, expected_failures, MODULE_CHECK_IDS)

    def case(check_id: str) -> Case:
        def run() -> None:
            _Checker(module_class, frames, seconds).run(only=check_id)

        return Case(f"{module_class.type_name}::{check_id}", run, declared.get(check_id))

    return [case(check_id) for check_id in MODULE_CHECK_IDS]


def _check_class(module_class: Any) -> None:
    if not (isinstance(module_class, type) and issubclass(module_class, Filter | Detector)):
        raise TypeError(f"{module_class!r} is neither a Filter nor a Detector subclass")


def check_all_modules(kind: str | None = None, **options: Any) -> dict[str, CheckReport]:
    """``check_module`` on every registered module type (of one kind, where given)."""
    return {name: check_module(klass, **options) for name, klass in module_types(kind).items()}


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
                frames = demo_frames(self.kind.name, spec)
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

    def steps(self) -> dict[str, Callable[[], None]]:
        """Each check by id; the last three share a value set far from the defaults, made when first needed."""
        alternative: list[Mapping[str, Any]] = []

        def far() -> Mapping[str, Any]:
            if not alternative:
                alternative.append(self.alternative_values())
            return alternative[0]

        return {
            "declarations": self.check_declarations,
            "refusals": self.check_refusals,
            "defaults": self.check_defaults_process,
            "boundaries": self.check_boundaries,
            "change-events": self.check_change_events,
            "repr": lambda: self.check_repr(far()),
            "round-trip": lambda: self.check_round_trip(far()),
            "snapshots": lambda: self.check_snapshots(far()),
            "search-space": lambda: check_search_space(self),
        }

    def run(self, declared: Mapping[str, str] | None = None, only: str | None = None) -> CheckReport:
        """Every check in order (or the one ``only`` names), applying the declared deviations."""
        start = time.perf_counter()
        steps = self.steps()
        with registered(self.cls):
            for check_id in MODULE_CHECK_IDS if only is None else (only,):
                run_declared(f"{self.name}::{check_id}", steps[check_id], (declared or {}).get(check_id),
                             self.report.deviations)
            self.begin("done")
        self.report.checks.pop()
        self.report.seconds = time.perf_counter() - start
        log.info("%s passed %d checks: %d frames, %d values refused, %.2f s CPU at most per frame", self.name,
                 len(self.report.checks), self.report.frames, self.report.refused, self.report.frame_cpu_seconds)
        return self.report

    # -- processing one frame -----------------------------------------------------------------------------
    def process(self, module: Parametrizable, data: Any, parameter: str | None = None, value: Any = None) -> Any:
        """One frame in a worker thread, allowed ``seconds`` of CPU time, with every output check."""
        try:
            result, used = call_with_cpu_limit(lambda: self.process_here(module, data, parameter, value),
                                               self.seconds, name=f"check_module {self.name}")
        except CPULimitExceeded as exc:
            self.fail(f"one frame {exc}", parameter, value, cause=exc)
            raise  # unreachable
        self.report.frame_cpu_seconds = max(self.report.frame_cpu_seconds, used)
        log.debug("%s: frame in %.3f s of CPU", self.name, used)
        return result

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
        if not same_values(module.get_parameters(), self.defaults):
            self.fail(f"a new module's values are not the declared defaults: "
                      f"{differences(self.defaults, module.get_parameters())}")
        for name in self.names:
            if not same(getattr(module.params, name), self.defaults[name]):
                self.fail("the snapshot does not hold the default", name, getattr(module.params, name))
        unknown = "no_such_parameter"
        while unknown in self.names:
            unknown += "_really"
        self.expect_refusal(module, unknown, 1, "an undeclared parameter")

    def expect_refusal(self, module: Parametrizable, name: str, value: Any, why: str) -> None:
        """``set_parameters(name=value)`` must raise ParameterError naming all three and change nothing."""
        before = module.get_parameters()
        recorder = Recorder()
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
        if not same_values(before, after):
            self.fail(f"the refusal of {why} changed values: {differences(before, after)}", name, value)
        if recorder.calls:
            self.fail(f"observers were notified of a refused value ({why})", name, value)
        self.report.refused += 1

    def check_refusals(self) -> None:
        self.begin("refusals")
        module = self.make()
        for spec in self.cls.parameter_specs():
            for why, value in spec.invalid_examples():
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
            for value in spec.boundary_values():
                module.set_parameters(**self.defaults)
                try:
                    module.set_parameters(**{name: value})
                except ParameterError as exc:
                    self.explain_rule_refusal(module, name, value, exc)
                    continue
                except Exception as exc:
                    self.fail(f"a boundary value raised {type(exc).__name__}: {exc}", name, value, cause=exc)
                held = getattr(module.params, name)
                if not same(held, value):
                    self.fail(f"the boundary value was accepted but the snapshot holds {short_repr(held)}",
                              name, value)
                if not same(value, self.defaults[name]):  # the defaults' frames were processed already
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
        recorder = Recorder()
        module.add_observer(recorder)
        try:
            for spec in self.cls.parameter_specs():
                name, default = spec.name, self.defaults[spec.name]
                allowed = [v for v in spec.alternatives(default) if self.allowed(module, {**self.defaults, name: v})]
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

    def expect_change(self, module: Parametrizable, recorder: Recorder, name: str, old: Any, new: Any) -> None:
        if len(recorder.calls) != 1:
            self.fail(f"one value set notified observers {len(recorder.calls)} times, not once", name, new)
        subject, changes = recorder.calls[0]
        if subject is not module:
            self.fail(f"observers were told the subject is {subject!r}, not the module", name, new)
        if len(changes) != 1:
            self.fail(f"one value set carried {len(changes)} changes: {changes}", name, new)
        got = changes[0]
        if got.subject is not module or got.name != name or not same(got.old, old) or not same(got.new, new):
            self.fail(f"expected Change({name}, {old!r}, {new!r}), observers got Change({got.name}, {got.old!r}, "
                      f"{got.new!r})", name, new)

    def alternative_values(self) -> dict[str, Any]:
        """A complete valid value set with every parameter off its default where the rules allow: each gets
        another value where one is allowed together with those chosen before it."""
        module = self.make()
        chosen = dict(self.defaults)
        for spec in self.cls.parameter_specs():
            for value in spec.alternatives(self.defaults[spec.name]):
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
                if not same(getattr(module.params, name), value):
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
            if not same_values(expected, got):
                self.fail(f"the file did not restore every value: {differences(expected, got)}")
            if keeps:
                self.compare_state(state, rebuilt.get_state(), "build_system")
            try:
                ParameterStorage(system).load_parameters(path)
            except Exception as exc:
                self.fail(f"load_parameters into the same module failed: {type(exc).__name__}: {exc}", cause=exc)
            if not same_values(expected, module.get_parameters()):
                self.fail(f"loading its own file changed values: {differences(expected, module.get_parameters())}")
            if keeps:
                self.compare_state(state, module.get_state(), "load_parameters")
        self.process(rebuilt, self.frames[0])

    def compare_state(self, before: Any, after: Any, how: str) -> None:
        try:
            saved, restored = as_file_data(before), as_file_data(after)
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
        if same_values(first, second):
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
                    if not any(all(same(g, a) for g, a in zip(got, want, strict=True)) for want in allowed):
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
        with switch_interval(1e-5):
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
            parts = [f"{n}={short_repr(v)} ({'first' if same(v, first[n]) else 'second'} set)"
                     for n, v in mixed.items() if not same(first[n], second[n])]
            self.fail("a snapshot read while another thread set parameters mixes the two value sets: "
                      + ", ".join(parts))
        if writes[0] < 2:
            self.fail("no value set was applied while the snapshots were read")
