"""States of your own in the patrol: what a task does at a goal pose, and the registry mission files use.

Nav2's waypoint follower runs a task plugin at each waypoint; here a task is a :class:`StateTask` and
each one placed at a pose becomes a state of its own inside ``PATROL`` (``POSE_3`` then ``POSE_3_WAIT``,
``POSE_3_DETECT``, ...), so it is entered, left, logged, preempted and drawn like every built-in state.
A :class:`StateTask` can also run as a monitor region beside the battery monitors
(:class:`navigation.patrol.Monitor`).

Write a task by subclassing :class:`PoseTask` (declare ``kind``, ``state``, ``options``; implement
:meth:`StateTask.start`), and make mission files know it with :func:`register_task`. Nothing is patched:
the machine is built from the tasks it is given. Built-in tasks (``wait``, ``photo``, ``look_around``)
live in :mod:`navigation.task_library`.
"""

from __future__ import annotations

import importlib
import logging
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from .clock import Timer
from .geometry import Pose2D

if TYPE_CHECKING:  # pragma: no cover
    from .patrol import PatrolMachine
    from .simulation import Simulation

log = logging.getLogger(__name__)

#: How a task may end; ``succeeded`` goes on to the next task (or pose), ``aborted`` to the next pose
#: (or SHUTDOWN with ``stop_on_failure``), ``preempted`` to SHUTDOWN. Monitors may end with their own words.
TASK_RESULTS = ("succeeded", "aborted", "preempted")

REQUIRED = object()
OPTION_TYPES = ("number", "integer", "text", "flag", "numbers", "path")


class TaskSpecError(ValueError):
    """A task in a mission that cannot be built; the message names the task and the field."""


@dataclass(frozen=True)
class TaskOption:
    """One option of a task type as mission files write it (``type``: one of :data:`OPTION_TYPES`)."""

    default: Any
    doc: str
    type: str = "number"
    min: float | None = None
    max: float | None = None


@dataclass
class Capture:
    """One camera frame taken at a pose, with the pose the robot believed it had when it took it."""

    frame: Any
    pose: Pose2D
    t: float
    label: str = ""


@dataclass
class TaskOutcome:
    state: str
    kind: str
    status: str
    text: str
    t: float


@dataclass
class Visit:
    """One arrival at a goal pose and the tasks done there; apps keep their results in ``data``.

    ``frames`` hold the captures of this visit for the tasks that follow (a ``detect`` after a
    ``look_around``); they are dropped when the visit ends, so a long patrol keeps no images.
    """

    number: int
    pose_index: int
    name: str
    lap: int
    goal: Pose2D
    started: float
    goal_status: str = ""
    arrived: Pose2D | None = None
    ended: float | None = None
    tasks: list[TaskOutcome] = field(default_factory=list)
    frames: list[Capture] = field(default_factory=list)
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def reached(self) -> bool:
        return self.goal_status == "SUCCEEDED"


class StateTask(ABC):
    """What an added state does while it is active.

    :meth:`start` is called on entering the state; the task ends by calling ``ctx.succeed()``,
    ``ctx.fail(text)`` or ``ctx.finish(result, text)``, at once or later from a timer (``ctx.after``).
    Leaving the state for any other reason (Ctrl-C, a battery monitor) calls :meth:`cancel`; timers made
    through the context and any driving it started stop by themselves.
    """

    #: The state's name (upper case): ``WAIT`` becomes ``POSE_3_WAIT`` at pose 3, or the monitor region.
    state: ClassVar[str]

    @abstractmethod
    def start(self, ctx: TaskContext) -> None:
        """Begin the work; finish through ``ctx``."""

    def cancel(self, ctx: TaskContext) -> None:  # noqa: B027 - most tasks need nothing beyond ctx.close()
        """The state is being left before the task finished."""

    def describe(self) -> str:
        return self.state.lower()


class PoseTask(StateTask):
    """A task that mission files name (``- wait: 2``); options are declared, parsed and checked here."""

    #: The name in mission files and events ("wait", "look_around").
    kind: ClassVar[str]
    summary: ClassVar[str] = ""
    options: ClassVar[Mapping[str, TaskOption]] = {}
    #: The option a bare value sets (``- wait: 2`` sets ``seconds``).
    positional: ClassVar[str | None] = None

    def __init__(self, **values: Any) -> None:
        unknown = set(values) - set(self.options)
        if unknown:
            raise TaskSpecError(f"{self.kind}: unknown option(s) {', '.join(sorted(unknown))}")
        self.values = {name: values.get(name, opt.default) for name, opt in self.options.items()}

    @classmethod
    def from_options(cls, given: Any, base_dir: Path) -> PoseTask:
        """The task from what a mission file gives: nothing, a bare value, or a mapping of options."""
        if given is None:
            given = {}
        elif not isinstance(given, Mapping):
            if cls.positional is None:
                raise TaskSpecError(f"{cls.kind}: takes options as a mapping, got {given!r}")
            given = {cls.positional: given}
        values: dict[str, Any] = {}
        for name, value in given.items():
            if name not in cls.options:
                known = ", ".join(cls.options) or "none"
                raise TaskSpecError(f"{cls.kind}: field '{name}': unknown option (options: {known})")
            values[name] = parse_option(cls.kind, str(name), cls.options[name], value, base_dir)
        for name, opt in cls.options.items():
            if opt.default is REQUIRED and name not in values:
                raise TaskSpecError(f"{cls.kind}: field '{name}': missing ({opt.doc})")
        return cls(**values)

    def describe(self) -> str:
        """``look_around headings=-20/0/20 settle=0.3``: the kind and its option values, for events."""
        shown = [f"{k}={_shown(v)}" for k, v in self.values.items() if v is not REQUIRED]
        return " ".join([self.kind, *shown])


def _shown(value: Any) -> str:
    if isinstance(value, tuple):
        return "/".join(_shown(v) for v in value)
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:g}"
    return str(value.name if isinstance(value, Path) else value)


def parse_option(kind: str, name: str, opt: TaskOption, value: Any, base_dir: Path) -> Any:
    """Check one option's value against its declaration; errors name the task and the field."""
    where = f"{kind}: field '{name}'"

    def number(v: Any) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise TaskSpecError(f"{where}: expected a number, got {v!r}")
        if (opt.min is not None and v < opt.min) or (opt.max is not None and v > opt.max):
            raise TaskSpecError(f"{where}: {v!r} is outside [{opt.min}, {opt.max}]")
        return float(v)

    if opt.type == "number":
        return number(value)
    if opt.type == "integer":
        if isinstance(value, bool) or not isinstance(value, int):
            raise TaskSpecError(f"{where}: expected a whole number, got {value!r}")
        return int(number(value))
    if opt.type == "flag":
        if not isinstance(value, bool):
            raise TaskSpecError(f"{where}: expected true or false, got {value!r}")
        return value
    if opt.type == "numbers":
        if not isinstance(value, list) or not value:
            raise TaskSpecError(f"{where}: expected a non-empty list of numbers, got {value!r}")
        return tuple(number(v) for v in value)
    if not isinstance(value, str) or not value.strip():
        raise TaskSpecError(f"{where}: expected text, got {value!r}")
    if opt.type == "path":
        path = Path(value).expanduser()
        return path if path.is_absolute() else base_dir / path
    return value


# -- the registry ---------------------------------------------------------------------------------------
_TASK_TYPES: dict[str, type[PoseTask]] = {}
_BUILTINS = "navigation.task_library"


def register_task(cls: type[PoseTask]) -> type[PoseTask]:
    """Make a task type known to mission files under ``cls.kind`` (usable as a class decorator)."""
    kind = getattr(cls, "kind", "")
    if not kind or not getattr(cls, "state", ""):
        raise TypeError(f"{cls.__name__} needs the class attributes 'kind' and 'state'")
    if not cls.state.replace("_", "").isalnum() or cls.state.upper() != cls.state:
        raise TypeError(f"{cls.__name__}.state must be upper-case letters, digits and '_', got {cls.state!r}")
    for name, opt in cls.options.items():
        if opt.type not in OPTION_TYPES:
            raise TypeError(f"{cls.__name__}: option {name!r} has unknown type {opt.type!r}")
    previous = _TASK_TYPES.get(kind)
    if previous is not None and previous is not cls:
        log.info("task type %r: %s replaces %s", kind, cls.__qualname__, previous.__qualname__)
    _TASK_TYPES[kind] = cls
    return cls


def unregister_task(kind: str) -> None:
    """Forget a task type (a test's own, or a plug-in being reloaded); unknown names are ignored."""
    _TASK_TYPES.pop(kind, None)


def task_types() -> dict[str, type[PoseTask]]:
    """Every registered task type by mission-file name, the built-in ones included."""
    importlib.import_module(_BUILTINS)  # registers wait, photo and look_around on first use
    return dict(_TASK_TYPES)


def make_task(item: Any, base_dir: Path) -> PoseTask:
    """A task from one mission-file entry: ``wait``, ``{wait: 2}`` or ``{look_around: {headings: [...]}}``."""
    if isinstance(item, str):
        kind, given = item, None
    elif isinstance(item, Mapping) and len(item) == 1:
        kind, given = next(iter(item.items()))
    else:
        raise TaskSpecError(f"expected a task name or a one-key mapping (task: options), got {item!r}")
    types = task_types()
    if kind not in types:
        raise TaskSpecError(f"unknown task {kind!r} (known: {', '.join(sorted(types))})")
    return types[kind].from_options(given, base_dir)


# -- what a running task may use ------------------------------------------------------------------------
class TaskContext:
    """The simulation, the camera, the visit, timers that die with the task, and how to finish."""

    def __init__(self, machine: PatrolMachine, state: str, task: StateTask, visit: Visit | None,
                 on_finish: Callable[[str, str, dict[str, Any]], None]) -> None:
        self.machine = machine
        self.state = state
        self.task = task
        self.visit = visit
        self._on_finish = on_finish
        self._timers: list[Timer] = []
        self._driving = False
        self.finished = False

    @property
    def sim(self) -> Simulation:
        return self.machine.sim

    @property
    def now(self) -> float:
        return self.machine.sim.clock.now

    def pose(self) -> Pose2D:
        """Where the robot believes it is (what move_base drives on)."""
        return self.machine.believed_pose()

    def capture(self, label: str = "") -> Capture:
        """A camera frame now; the capture is kept with the visit for the tasks after this one."""
        if self.machine.camera is None:
            raise RuntimeError("this patrol has no camera")
        shot = Capture(self.machine.camera(), self.pose(), self.now, label)
        if self.visit is not None:
            self.visit.frames.append(shot)
        return shot

    def after(self, seconds: float, callback: Callable[[], None]) -> Timer:
        timer = self.sim.clock.call_later(seconds, callback)
        self._timers.append(timer)
        return timer

    def every(self, period: float, callback: Callable[[], None], first: float | None = None) -> Timer:
        timer = self.sim.clock.every(period, callback, first)
        self._timers.append(timer)
        return timer

    def drive(self, v: float, w: float) -> None:
        """Command the base directly (move_base is idle during tasks)."""
        self._driving = True
        self.sim.teleop = (v, w)

    def emit(self, kind: str, **fields: Any) -> None:
        """An event stamped with this task's state and visit."""
        visit = {"visit": self.visit.number, "pose": self.visit.name} if self.visit is not None else {}
        self.sim.events.emit(kind, state=self.state, **visit, **fields)

    def succeed(self, text: str = "", **fields: Any) -> None:
        self.finish("succeeded", text, **fields)

    def fail(self, text: str, **fields: Any) -> None:
        self.finish("aborted", text, **fields)

    def finish(self, result: str, text: str = "", **fields: Any) -> None:
        """End the task with ``result`` (a trigger: succeeded, aborted, preempted, or a monitor's own)."""
        if self.finished:
            return
        self.close()
        self._on_finish(result, text, fields)

    def close(self) -> None:
        """Stop the task's timers and any driving it started; called on finishing and on leaving the state."""
        self.finished = True
        for timer in self._timers:
            timer.cancel()
        self._timers.clear()
        if self._driving:
            self._driving = False
            self.sim.teleop = None
            self.sim.robot.stop()
