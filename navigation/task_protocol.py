"""What the task side needs of a patrol machine, as protocols, so that it never imports the machine.

:mod:`navigation.patrol` builds a :class:`~navigation.task_runner.TaskRunner` and runs
:class:`~navigation.tasks.StateTask` objects; the runner and the tasks in turn call back into the machine
(its simulation, its camera, its triggers). Naming the machine's class there made the three modules import
each other. They depend on these protocols instead, which :class:`~navigation.patrol.PatrolMachine` and
:class:`~navigation.patrol.Monitor` satisfy by their shape: the dependency runs one way, patrol to tasks.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Protocol

from .geometry import Pose2D

if TYPE_CHECKING:  # pragma: no cover
    from .simulation import Simulation
    from .tasks import StateTask


class TaskHost(Protocol):
    """The machine a task runs in: its simulation and camera, where it believes it is, how it moves on."""

    sim: Simulation
    camera: Callable[[], Any] | None

    def believed_pose(self) -> Pose2D:
        """Where navigation believes the robot is."""

    def pose_done(self, index: int) -> None:
        """Every task at pose ``index`` is over (or one aborted): the patrol goes on to the next pose."""

    def trigger(self, name: str) -> Any:
        """Fire the machine's transition ``name`` (succeeded, aborted, preempted or a monitor's own)."""


class MonitorTask(Protocol):
    """A task running beside the patrol; its ``outcomes`` map its own results to the states they lead to."""

    @property
    def task(self) -> StateTask: ...

    @property
    def outcomes(self) -> Mapping[str, str]: ...

    @property
    def state(self) -> str: ...
