"""A recognition system: the object's name and the pipeline of filters and detectors, in order."""

from __future__ import annotations

import threading
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from .messages import DetectedObjectArray
from .modules import Detector, Filter, detection_reason
from .observer import Change, Subject
from .parametrizable import Parametrizable


class PipelineError(ValueError):
    """A pipeline that cannot work: duplicate ids, modules of different kinds, no detector where one is needed."""


@dataclass
class Stage:
    """One step's result, for views that show every stage (not only the last)."""

    id: str
    type_name: str
    role: str  # "input", "filter" or "detector"
    output: Any
    objects: list[Any] = field(default_factory=list)
    debug: Any = None


@dataclass
class PipelineResult:
    objects: list[Any]
    stages: list[Stage] | None = None
    detector_inputs: dict[str, Any] = field(default_factory=dict)
    #: Each detector of the frame's pipeline and how many objects it found (why a frame is empty, per detector).
    found: list[tuple[Any, int]] = field(default_factory=list)
    #: Per detector id, why it found nothing in this frame (its result's ``reason``); None where it found
    #: objects or gives no reason. Carried with the frame's result, never read back from the detector.
    reasons: dict[str, str | None] = field(default_factory=dict)


@dataclass(frozen=True)
class _Plan:
    """What a frame's run needs to know of the pipeline, worked out once when the pipeline changes rather than
    per frame: each module with whether it is a filter (``isinstance`` on the abstract bases costs about half a
    microsecond a module), and the message type of the results. Replaced with the module tuple, never mutated,
    so a frame reads one consistent plan."""

    steps: tuple[tuple[bool, Any], ...]
    array_type: type[DetectedObjectArray]

    @classmethod
    def of(cls, modules: Sequence[Parametrizable]) -> _Plan:
        detectors = [m for m in modules if isinstance(m, Detector)]
        array_type = detectors[0].object_array_type if detectors else DetectedObjectArray
        return cls(tuple((isinstance(m, Filter), m) for m in modules), array_type)

    def detect_objects(self, data: Any) -> list[Any]:
        """The objects this plan's detectors find in ``data`` (see ``RecognitionSystem.detect_objects``)."""
        objects: list[Any] = []
        for is_filter, m in self.steps:
            if is_filter:
                data = m.filter(data)
            else:
                objects += m.detect(data)
        return objects


class RecognitionSystem(Subject):
    """Filters transform the frame in order; each detector finds objects in the frame as it stands at
    its place in the pipeline. All modules must be of one kind (2d or 3d).

    The module list is replaced, never mutated, so a worker thread processing a frame is unaffected by a
    GUI thread adding or removing a module; observers hear of every pipeline change.
    """

    def __init__(
        self,
        modules: Iterable[Parametrizable] = (),
        object_name: str = "object",
        kind: str | None = None,
        description: str = "",
    ) -> None:
        super().__init__()
        self._lock = threading.RLock()
        self._object_name = object_name
        self._description = description
        self._kind = kind
        self._modules: tuple[Parametrizable, ...] = ()
        self._plan: _Plan = _Plan.of(())
        self.set_modules(list(modules), notify=False)

    @property
    def lock(self) -> threading.RLock:
        """Held while the pipeline changes; hold it to make several changes one."""
        return self._lock

    # -- structure ------------------------------------------------------------------------------------
    @property
    def object_name(self) -> str:
        """The name detected objects carry, unless a detector has a name of its own."""
        return self._object_name

    @object_name.setter
    def object_name(self, name: str) -> None:
        self.set_identity(name, self._description)

    @property
    def description(self) -> str:
        return self._description

    @description.setter
    def description(self, text: str) -> None:
        self.set_identity(self._object_name, text)

    def set_identity(self, object_name: str, description: str, notify: bool = True) -> None:
        """Set the object's name and the description; observers hear of a change."""
        if not isinstance(object_name, str) or not object_name.strip():
            raise ValueError(f"the object name must be non-empty text, got {object_name!r}")
        changes = [Change(self, name, old, new) for name, old, new in (
            ("object_name", self._object_name, object_name), ("description", self._description, description))
            if old != new]
        with self._lock:
            self._object_name, self._description = object_name, description
            for d in self.detectors:
                d.system_object_name = object_name
        if changes and notify:
            self.notify(changes)

    @property
    def modules(self) -> tuple[Parametrizable, ...]:
        return self._modules

    @property
    def filters(self) -> list[Filter]:
        return [m for m in self._modules if isinstance(m, Filter)]

    @property
    def detectors(self) -> list[Detector]:
        return [m for m in self._modules if isinstance(m, Detector)]

    @property
    def kind(self) -> str | None:
        """The data kind; taken from the modules when not given."""
        if self._kind is not None:
            return self._kind
        kinds = {m.kind for m in self._modules if m.kind}
        return kinds.pop() if len(kinds) == 1 else None

    @property
    def object_array_type(self) -> type[DetectedObjectArray]:
        return self._plan.array_type

    def module(self, module_id: str) -> Parametrizable:
        for m in self._modules:
            if m.id == module_id:
                return m
        raise KeyError(f"no module with id {module_id!r} (ids: {', '.join(m.id for m in self._modules)})")

    @staticmethod
    def check_modules(modules: Sequence[Parametrizable], kind: str | None = None) -> None:
        """Raise PipelineError if these modules cannot form one pipeline."""
        seen: set[str] = set()
        for m in modules:
            if not isinstance(m, Filter | Detector):
                raise PipelineError(f"{m!r} is neither a Filter nor a Detector")
            if m.id in seen:
                raise PipelineError(f"two modules have the id {m.id!r}; give each its own id")
            seen.add(m.id)
        kinds = {m.kind for m in modules if m.kind} | ({kind} if kind else set())
        if len(kinds) > 1:
            raise PipelineError(f"modules of different kinds cannot share a pipeline: {sorted(kinds)}")
        array_types = {m.object_array_type for m in modules if isinstance(m, Detector)}
        if len(array_types) > 1:
            raise PipelineError("detectors in one pipeline must report the same message type")

    def set_modules(self, modules: Sequence[Parametrizable], kind: str | None = None, notify: bool = True) -> None:
        """Replace the pipeline (and, where given, the data kind) at once."""
        modules = tuple(modules)
        self.check_modules(modules, kind or self._kind)
        with self._lock:
            for m in modules:
                if isinstance(m, Detector):
                    m.system_object_name = self._object_name
            old, self._modules = self._modules, modules
            self._plan = _Plan.of(modules)
            if kind is not None:
                self._kind = kind
        if notify:
            self.notify([Change(self, "pipeline", old, modules)])

    def add_module(self, module: Parametrizable, index: int | None = None) -> None:
        with self._lock:
            modules = list(self._modules)
            modules.insert(len(modules) if index is None else index, module)
            self.set_modules(modules)

    def remove_module(self, module_id: str) -> Parametrizable:
        with self._lock:
            module = self.module(module_id)
            self.set_modules([m for m in self._modules if m is not module])
            return module

    def move_module(self, module_id: str, index: int) -> None:
        with self._lock:
            module = self.module(module_id)
            modules = [m for m in self._modules if m is not module]
            modules.insert(index, module)
            self.set_modules(modules)

    def unique_id(self, base: str) -> str:
        """An id not yet used in this system (for a second module of one type)."""
        ids = {m.id for m in self._modules}
        if base not in ids:
            return base
        n = 2
        while f"{base}_{n}" in ids:
            n += 1
        return f"{base}_{n}"

    # -- processing -----------------------------------------------------------------------------------
    def detect_objects(self, data: Any) -> list[Any]:
        """The objects ``process(data).objects`` holds, without the per-detector counts and reasons: a headless
        run where nothing asks why a frame is empty makes no record it would throw away (a handful of Python
        calls a frame, which show against bare OpenCV on small frames: benchmarks/bench_2d.py)."""
        return self._plan.detect_objects(data)

    @property
    def plan(self) -> _Plan:
        """The pipeline as a frame runs it (``steps``, ``array_type``, ``detect_objects``): replaced whole when
        the pipeline changes, so a caller that takes it once per frame gets modules and message type that
        belong together."""
        return self._plan

    def process(self, data: Any, keep_stages: bool = False) -> PipelineResult:
        """Run the pipeline on one frame's data.

        With ``keep_stages`` every stage's output and each detector's debug view are kept for a view;
        without, nothing is copied or kept (the headless path).
        """
        plan = self._plan
        objects: list[Any] = []
        counts: list[tuple[Any, int]] = []
        reasons: dict[str, str | None] = {}
        if not keep_stages:
            for is_filter, m in plan.steps:
                if is_filter:
                    data = m.filter(data)
                else:
                    found = m.detect(data)
                    objects.extend(found)
                    counts.append((m, len(found)))
                    reasons[m.id] = None if found else detection_reason(m, found)
            return PipelineResult(objects, None, {}, counts, reasons)
        stages = [Stage("input", "input", "input", data)]
        inputs: dict[str, Any] = {}
        for is_filter, m in plan.steps:
            if is_filter:
                data = m.filter(data)
                stages.append(Stage(m.id, m.type_name, "filter", data))
            else:
                found = m.detect(data)
                inputs[m.id] = data
                objects.extend(found)
                counts.append((m, len(found)))
                reasons[m.id] = detection_reason(m, found)
                stages.append(Stage(m.id, m.type_name, "detector", data, found, m.render_debug(data, found)))
        return PipelineResult(objects, stages, inputs, counts, reasons)
