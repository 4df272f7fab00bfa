"""The patrol's task registry is the shared one (declare.registry): built-in tasks come from the
``objrec.tasks`` entry points, keyed by their mission-file name, and a task may not take another's name."""

from __future__ import annotations

from typing import ClassVar

import pytest

from navigation.task_library import WaitTask
from navigation.tasks import (
    TASK_GROUP,
    TASKS,
    PoseTask,
    TaskContext,
    TaskSpecError,
    register_task,
    task_types,
    unregister_task,
)


def test_built_in_tasks_are_entry_points_of_their_mission_file_names():
    assert TASKS.group == TASK_GROUP == "objrec.tasks"
    declared = {name: eps[0].value for name, eps in TASKS.entry_points().items()}
    assert {"wait", "photo", "look_around"} <= set(declared)
    assert declared["wait"] == "navigation.task_library:WaitTask"
    assert task_types()["wait"] is WaitTask


def test_a_task_may_not_take_a_built_in_name():
    class OtherWait(PoseTask):
        kind = "wait"
        state = "OTHER_WAIT"
        options: ClassVar = {}

        def start(self, ctx: TaskContext) -> None:
            ctx.succeed()

    with pytest.raises(TaskSpecError, match=r"task type 'wait' is (installed as navigation.task_library:WaitTask"
                                            r"|already registered by navigation.task_library:WaitTask)"):
        register_task(OtherWait)
    assert task_types()["wait"] is WaitTask
    register_task(WaitTask)  # the same class again is no clash


def test_a_task_registered_in_code_is_found_and_forgotten():
    class Chirp(PoseTask):
        kind = "chirp"
        state = "CHIRP"
        options: ClassVar = {}

        def start(self, ctx: TaskContext) -> None:
            ctx.succeed()

    register_task(Chirp)
    try:
        assert task_types()["chirp"] is Chirp
    finally:
        unregister_task("chirp")
    assert "chirp" not in task_types()
    with pytest.raises(TypeError, match="is not a PoseTask subclass"):
        register_task(int)  # type: ignore[arg-type]
