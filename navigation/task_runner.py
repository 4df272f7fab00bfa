"""Running the added states of one patrol machine, and keeping its visits.

The machine (:mod:`navigation.patrol`) only knows that a state is a task state; this class knows which
task it is, gives it a :class:`~navigation.tasks.TaskContext`, turns its ending into the machine's
trigger, and keeps one :class:`~navigation.tasks.Visit` per arrival at a pose, so an app can report what
was found where, visit by visit, even when the run is cut short.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any

from .geometry import Pose2D
from .task_protocol import MonitorTask, TaskHost
from .tasks import TASK_RESULTS, StateTask, TaskContext, TaskOutcome, Visit

log = logging.getLogger(__name__)


class TaskRunner:
    """Starts and stops the tasks and monitors of a machine; ``visits`` lists every visit so far."""

    def __init__(self, machine: TaskHost, names: list[list[str]], tasks: Sequence[Sequence[StateTask]],
                 monitors: Sequence[MonitorTask], patrol_prefix: str, region_prefix: str) -> None:
        self.machine = machine
        self._at: dict[str, tuple[int, int, StateTask]] = {}
        self._chain: list[int] = [len(row) for row in names]
        for i, row in enumerate(names):
            for k, name in enumerate(row):
                self._at[patrol_prefix + name] = (i, k, tasks[i][k])
        self._monitors = {region_prefix + m.state: m for m in monitors}
        self._contexts: dict[str, TaskContext] = {}
        self.visit: Visit | None = None
        self.visits: list[Visit] = []
        self.listeners: list[Callable[[Visit], None]] = []

    def is_pose_task(self, state: str) -> bool:
        return state in self._at

    def has_tasks(self, pose_index: int) -> bool:
        return bool(self._chain[pose_index])

    # -- visits -----------------------------------------------------------------------------------------
    def entered(self, state: str) -> None:
        """Any state entered: a state that is not a task of the open visit's pose ends that visit."""
        visit = self.visit
        if visit is None or state in self._monitors:
            return
        owner = self._at.get(state)
        if owner is None or owner[0] != visit.pose_index:
            self.end_visit()

    def begin_visit(self, pose_index: int, goal: Pose2D, name: str, lap: int) -> Visit:
        self.end_visit()
        visit = Visit(len(self.visits) + 1, pose_index, name, lap, goal, self.machine.sim.clock.now)
        self.visits.append(visit)
        self.visit = visit
        return visit

    def goal_result(self, status: str, pose: Pose2D) -> None:
        if self.visit is not None:
            self.visit.goal_status = status
            self.visit.arrived = pose

    def end_visit(self) -> None:
        """Close the open visit: its frames are dropped, then the listeners see it."""
        visit = self.visit
        if visit is None:
            return
        self.visit = None
        visit.ended = self.machine.sim.clock.now
        self.machine.sim.events.emit(
            "visit", visit=visit.number, pose=visit.name, lap=visit.lap, goal_status=visit.goal_status or "none",
            tasks=[[t.state.rsplit(".", 1)[-1], t.status] for t in visit.tasks])
        try:
            for listener in list(self.listeners):
                listener(visit)
        finally:
            visit.drop_frames()

    # -- tasks ------------------------------------------------------------------------------------------
    def start(self, state: str) -> None:
        owner = self._at.get(state)
        task = owner[2] if owner is not None else self._monitors[state].task
        visit = self.visit if owner is not None else None
        ctx = TaskContext(self.machine, state, task, visit,
                          lambda result, text, fields: self._finished(state, ctx, result, text, fields))
        self._contexts[state] = ctx
        kind = getattr(task, "kind", task.state.lower())
        ctx.emit("task_start", task=kind, what=task.describe())
        ctx.guard(lambda: task.start(ctx))  # a broken task aborts itself, not the patrol

    def stop(self, state: str) -> None:
        """The state is left: a task still running is cancelled and its ending ignored.

        A task at a pose ends ``preempted``; a monitor only stops watching (``task_stop``), which is no result and
        no failure: it stops each time its region is left and starts again in the next state it watches in."""
        ctx = self._contexts.pop(state, None)
        if ctx is None or ctx.finished:
            return
        ctx.close()
        try:
            ctx.task.cancel(ctx)
        finally:
            kind = getattr(ctx.task, "kind", ctx.task.state.lower())
            if state in self._monitors:
                ctx.emit("task_stop", task=kind, text="state left")
            else:
                ctx.emit("task_result", task=kind, status="preempted", text="state left")
            if ctx.visit is not None:
                ctx.visit.tasks.append(TaskOutcome(state, getattr(ctx.task, "kind", ""), "preempted", "state left",
                                                   self.machine.sim.clock.now))

    def _finished(self, state: str, ctx: TaskContext, result: str, text: str, fields: dict[str, Any]) -> None:
        if self._contexts.get(state) is not ctx:
            return
        del self._contexts[state]
        kind = getattr(ctx.task, "kind", ctx.task.state.lower())
        ctx.emit("task_result", task=kind, status=result, text=text, **fields)
        owner = self._at.get(state)
        if owner is None:
            monitor = self._monitors[state]
            if result in monitor.outcomes:
                self.machine.trigger(result)
            else:
                log.warning("monitor %s ended with %r, which leads nowhere (outcomes: %s)", state, result,
                            ", ".join(monitor.outcomes) or "none")
            return
        index, position, _task = owner
        if result not in TASK_RESULTS:
            log.warning("task at %s ended with %r; a task at a pose ends with %s: taken as aborted", state, result,
                        ", ".join(TASK_RESULTS))
            result = "aborted"
        if ctx.visit is not None:
            ctx.visit.tasks.append(TaskOutcome(state, kind, result, text, self.machine.sim.clock.now))
        if result == "aborted" or (result == "succeeded" and position == self._chain[index] - 1):
            self.machine.pose_done(index)
        self.machine.trigger(result)
