"""States of your own in the patrol: what a task does at a goal pose, and the registry mission files use.

Nav2's waypoint follower runs a task plugin at each waypoint; here a task is a :class:`StateTask` and
each one placed at a pose becomes a state of its own inside ``PATROL`` (``POSE_3`` then ``POSE_3_WAIT``,
``POSE_3_DETECT``, ...), so it is entered, left, logged, preempted and drawn like every built-in state.
A :class:`StateTask` can also run as a monitor region beside the battery monitors
(:class:`navigation.patrol.Monitor`).

Write a task by subclassing :class:`PoseTask` (declare ``kind``, ``state``, ``options``; implement
:meth:`StateTask.start`), and make mission files know it with an ``objrec.tasks`` entry point (name = its
``kind``) or :func:`register_task` in code (the shared rules of :mod:`declare.registry`). Nothing is patched:
the machine is built from the tasks it is given. Built-in tasks (``wait``, ``photo``, ``look_around``)
live in :mod:`navigation.task_library`.
"""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from declare.fields import (
    NO_VALUE,
    REQUIRED,
    DocumentError,
    FieldLike,
    Invalid,
    Place,
    Record,
    as_field,
    code_place,
)
from declare.registry import Registry

from . import frame_store
from .clock import Timer
from .geometry import Pose2D

if TYPE_CHECKING:  # pragma: no cover
    from .simulation import Simulation
    from .task_protocol import TaskHost

log = logging.getLogger(__name__)

#: How a task may end; ``succeeded`` goes on to the next task (or pose), ``aborted`` to the next pose
#: (or SHUTDOWN with ``stop_on_failure``), ``preempted`` to SHUTDOWN. Monitors may end with their own words.
TASK_RESULTS = ("succeeded", "aborted", "preempted")

class TaskSpecError(DocumentError):
    """A task that cannot be built: one of the document errors (file, line, key path, value, rule).

    Made with a bare message (``TaskSpecError("unknown task type 'x'")``, as the registry raises it) it names
    no file; read from a mission it names the mission file, the line and ``at.0.tasks[1].wait.seconds``.
    """

    def __init__(self, path: Any, key_path: str | None = None, rule: str | None = None, *,
                 line: int | None = None, value: Any = NO_VALUE) -> None:
        if key_path is None and rule is None:  # the message alone
            path, key_path, rule = "", "", str(path)
        super().__init__(path, key_path or "", rule or "", line=line, value=value)


class Capture:
    """One camera frame taken at a pose, with the pose the robot believed it had when it took it.

    Kept with a visit, its frame is on disk (:mod:`navigation.frame_store`) and :attr:`frame` reads it back each
    time it is asked for, so a task going through many captures holds one frame at a time."""

    __slots__ = ("_file", "_frame", "label", "pose", "t")

    def __init__(self, frame: Any, pose: Pose2D, t: float, label: str = "") -> None:
        self._frame: Any = frame
        self._file: Path | None = None
        self.pose, self.t, self.label = pose, t, label

    @property
    def frame(self) -> Any:
        return self._frame if self._file is None else frame_store.load(self._file)

    def spill(self, store: frame_store.FrameStore) -> None:
        """Move the frame into ``store`` (it stays in memory when the store cannot take it)."""
        if self._file is None:
            self._file = store.put(self._frame)
            if self._file is not None:
                self._frame = None

    def __repr__(self) -> str:
        where = f"file={self._file}" if self._file is not None else "in memory"
        return f"Capture({where}, pose={self.pose!r}, t={self.t!r}, label={self.label!r})"


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
    _store: frame_store.FrameStore = field(default_factory=frame_store.FrameStore, repr=False, compare=False)

    @property
    def reached(self) -> bool:
        return self.goal_status == "SUCCEEDED"

    def keep(self, shot: Capture) -> None:
        """Keep a capture for the tasks after this one, its frame on disk until the visit ends."""
        shot.spill(self._store)
        self.frames.append(shot)

    def drop_frames(self) -> None:
        """The visit is over: its captures and their files go."""
        self.frames.clear()
        self._store.close()


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
    #: Declared like module parameters (``Float``, ``Int``, ``Bool``, ``Str``, ``Choice``) or as document fields
    #: (``ListOf(Float(...))``, ``FilePath(required=True)``): checked, described and shown the same way.
    options: ClassVar[Mapping[str, FieldLike]] = {}
    #: The option a bare value sets (``- wait: 2`` sets ``seconds``).
    positional: ClassVar[str | None] = None

    def __init__(self, **values: Any) -> None:
        unknown = sorted(set(values) - set(self.options))
        if unknown:
            raise TaskSpecError(f"{self.kind}: unknown option(s) {', '.join(unknown)}")
        self.values = {name: values.get(name, as_field(opt).default) for name, opt in self.options.items()}

    @classmethod
    def table(cls) -> Record:
        """The task's options as a document table: a mapping of them, or the positional option's bare value."""
        return Record(cls.options, shorthand=cls.positional, null_is_empty=True)

    @classmethod
    def from_options(cls, given: Any, at: Place | Path) -> PoseTask:
        """The task from what a mission file gives at ``at``: nothing, a bare value, or a mapping of options."""
        if isinstance(at, Path):
            at = code_place(at, TaskSpecError).key(cls.kind)
        values = cls.table().read(given, at)
        try:
            return cls(**values)
        except Invalid as exc:  # the task's own check of its values (a parameter file that detects nothing)
            raise at.invalid(exc) from None

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


# -- the registry ---------------------------------------------------------------------------------------
def _valid_task(name: str, cls: Any) -> type[PoseTask]:
    """A task type mission files may name ``name``: a PoseTask with a kind, a state name and typed options."""
    if not (isinstance(cls, type) and issubclass(cls, PoseTask)):
        raise TypeError(f"{cls!r} is not a PoseTask subclass")
    kind = getattr(cls, "kind", "")
    if not kind or not getattr(cls, "state", ""):
        raise TypeError(f"{cls.__name__} needs the class attributes 'kind' and 'state'")
    if kind != name:
        raise TypeError(f"{cls.__name__}.kind is {kind!r}, not {name!r}")
    if not cls.state.replace("_", "").isalnum() or cls.state.upper() != cls.state:
        raise TypeError(f"{cls.__name__}.state must be upper-case letters, digits and '_', got {cls.state!r}")
    for option_name, opt in cls.options.items():
        try:
            as_field(opt)
        except TypeError as exc:
            raise TypeError(f"{cls.__name__}: option {option_name!r}: {exc}") from None
    return cls


#: The entry-point group of task types: name = the task's name in mission files, value = its PoseTask class.
TASK_GROUP = "objrec.tasks"

#: Task types by mission-file name: the ``objrec.tasks`` entry points (the built-in ``wait``, ``photo`` and
#: ``look_around`` of :mod:`navigation.task_library`, and plug-ins') and :func:`register_task` in code.
TASKS: Registry[type[PoseTask]] = Registry(TASK_GROUP, "task type", error=TaskSpecError, validate=_valid_task,
                                           name_of=lambda cls: getattr(cls, "kind", "") or repr(cls))


def register_task(cls: type[PoseTask]) -> type[PoseTask]:
    """Make a task type known to mission files under ``cls.kind`` (usable as a class decorator). TypeError
    for an incomplete class; TaskSpecError when another class holds the name."""
    TASKS.register(cls)
    return cls


def unregister_task(kind: str) -> None:
    """Forget a task type (a test's own, or a plug-in being reloaded); unknown names are ignored."""
    TASKS.unregister(kind)


def task_types() -> dict[str, type[PoseTask]]:
    """Every task type by mission-file name, the built-in ones included (loading their entry points);
    one that cannot be loaded is logged and left out."""
    return TASKS.items()


def make_task(item: Any, base_dir: Path, at: Place | None = None) -> PoseTask:
    """A task from one mission-file entry: ``wait``, ``{wait: 2}`` or ``{look_around: {headings: [...]}}``.

    ``at`` is where the entry stands in its mission file (errors name its line and key path); without it
    errors are :class:`TaskSpecError` naming the task and option (``beep.times``)."""
    if at is None:
        at = code_place(base_dir, TaskSpecError)
    if isinstance(item, str):
        kind, given = item, None
    elif isinstance(item, Mapping) and len(item) == 1:
        kind, given = next(iter(item.items()))
    else:
        raise at.fail("expected a task name or a one-key mapping (task: options)", item)
    if not isinstance(kind, str) or kind not in TASKS:
        raise at.fail(f"unknown task (known: {', '.join(TASKS.names())})", kind)
    try:
        task_type = TASKS.get(kind)
    except TaskSpecError as exc:  # a plug-in that cannot be loaded
        raise at.key(kind).fail(exc.rule) from None
    return task_type.from_options(given, at.key(kind))


# -- what a running task may use ------------------------------------------------------------------------
class TaskContext:
    """The simulation, the camera, the visit, timers that die with the task, and how to finish."""

    def __init__(self, machine: TaskHost, state: str, task: StateTask, visit: Visit | None,
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
            self.visit.keep(shot)
        return shot

    def after(self, seconds: float, callback: Callable[[], None]) -> Timer:
        timer = self.sim.clock.call_later(seconds, lambda: self.guard(callback))
        self._timers.append(timer)
        return timer

    def every(self, period: float, callback: Callable[[], None], first: float | None = None) -> Timer:
        timer = self.sim.clock.every(period, lambda: self.guard(callback), first)
        self._timers.append(timer)
        return timer

    def guard(self, call: Callable[[], None]) -> None:
        """Run a part of the task (its start, a timer's callback): an exception aborts this task only, with the
        error in its result, and the patrol goes on (one error line; the traceback at INFO, which a command's
        ``--verbose`` shows). A missing library (ImportError) is not the task's failure but the installation's:
        it ends the command, which names the extra to install."""
        try:
            call()
        except ImportError:
            raise
        except Exception as exc:
            kind = getattr(self.task, "kind", self.task.state.lower())
            log.error("task %s at %s failed: %s: %s", kind, self.state, type(exc).__name__, exc)
            log.info("where task %s failed:", kind, exc_info=True)
            self.fail(f"error: {type(exc).__name__}: {exc}")

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
