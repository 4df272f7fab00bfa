"""The patrol state machine, built with ``transitions``.

States and transitions are data (:func:`patrol_states`, :func:`patrol_transitions`); this module's
class only supplies what each state *does* when entered or left. Names and outcomes follow the ROS patrol's:

* ``MONITORED_PATROL`` (parallel) runs ``PATROL`` (``POSE_0``, ``POSE_1``, ... in a loop),
  ``ROBOT_BATTERY_MONITOR`` and the added monitors; the first to finish ends the others,
  because leaving any region leaves the whole parallel state.
* ``robot_battery_low`` goes to ``DOCK_AT_STATION`` (``MOVE_TO_STATION`` then ``DOCK``) when a station
  is known, else to ``SHUTDOWN``; ``preempted`` goes to ``SHUTDOWN``.
* Added monitors keep watching outside MONITORED_PATROL too (docking, charging, undocking, LOCALIZE): their
  outcomes lead to their states from there as well, so the laptop's monitor (:mod:`navigation.laptop_monitor`,
  which ``objrec-patrol`` adds) ends the run when the laptop dies on the dock; a monitor's outcome that leads to
  SHUTDOWN gives the run its reason (``end_reason``). An empty robot battery (not charging) ends the run from
  any state as ``robot_battery_empty``, named as such.
* ``DOCK_AT_STATION`` succeeds into ``WAIT_UNTIL_CHARGED``, any failure goes to ``SHUTDOWN``.
* ``WAIT_UNTIL_CHARGED`` ends in ``SHUTDOWN`` when charged or preempted, or, with
  ``resume_after_charging``, goes through ``UNDOCK`` back to ``MONITORED_PATROL`` at the goal that was
  interrupted.
* ``SHUTDOWN`` stops the robot; the machine's outcome is then ``shutdown``.
* ``localization_lost`` (amcl no longer trusts its pose) leaves PATROL for ``LOCALIZE``, which stops, turns and
  re-seeds the filter (:mod:`navigation.relocalize`); ``localized`` returns to MONITORED_PATROL at the goal that
  was interrupted, ``aborted`` (no confident pose after every stage) goes to ``SHUTDOWN`` with the reason.

States of your own are added without patching: tasks at the goal poses (:mod:`navigation.tasks`; each
becomes ``POSE_i_<TASK>`` after ``POSE_i``) and monitor regions beside the robot battery monitor
(:class:`Monitor`; the laptop's battery is one, :func:`navigation.laptop_monitor.laptop_battery_monitor`). The
machine is built from its own tables (:attr:`PatrolMachine.states_table`, ``transitions_table``), so the diagram
and the event log show the added states too.

Work is started on entry and cancelled on exit, and all waiting happens on the simulation clock.
A preemption request (Ctrl-C) is sticky, like smach's: the running action is cancelled, and any state
entered afterwards finishes at once with ``preempted``.
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from transitions.extensions.nesting import HierarchicalMachine, NestedState

from .geometry import Pose2D
from .move_base import GoalStatus
from .relocalize import Relocalize
from .robot_interface import PatrolRobot, TimerHandle
from .task_runner import TaskRunner
from .tasks import StateTask, Visit

log = logging.getLogger(__name__)

SEP = "."
OUTCOME = "shutdown"

MONITORED_PATROL = "MONITORED_PATROL"
PATROL = f"{MONITORED_PATROL}{SEP}PATROL"
ROBOT_MONITOR = f"{MONITORED_PATROL}{SEP}ROBOT_BATTERY_MONITOR"
DOCK_AT_STATION = "DOCK_AT_STATION"
MOVE_TO_STATION = f"{DOCK_AT_STATION}{SEP}MOVE_TO_STATION"
DOCK = f"{DOCK_AT_STATION}{SEP}DOCK"
WAIT_UNTIL_CHARGED = "WAIT_UNTIL_CHARGED"
UNDOCK = "UNDOCK"
SHUTDOWN = "SHUTDOWN"
LOCALIZE = "LOCALIZE"
#: Where a monitor's outcome may lead: the top-level states outside MONITORED_PATROL.
MONITOR_DESTINATIONS = (DOCK_AT_STATION, WAIT_UNTIL_CHARGED, UNDOCK, SHUTDOWN)
_BUILT_IN_TRIGGERS = ("start", "succeeded", "aborted", "preempted", "robot_battery_low", "robot_battery_empty",
                      "charged", "localization_lost", "localized")
#: The top-level states outside MONITORED_PATROL where the added monitors keep watching (SHUTDOWN ends everything).
OUTSIDE_STATES = (DOCK_AT_STATION, WAIT_UNTIL_CHARGED, UNDOCK, LOCALIZE)

RESULT_TRIGGER = {GoalStatus.SUCCEEDED: "succeeded", GoalStatus.ABORTED: "aborted",
                  GoalStatus.PREEMPTED: "preempted"}


def pose_state(i: int) -> str:
    return f"POSE_{i}"


@dataclass(frozen=True)
class Monitor:
    """A state of your own running beside the patrol inside MONITORED_PATROL, as the robot battery monitor does.

    ``task`` watches (its ``state`` names the region); when it finishes with one of the words in
    ``outcomes`` (its own trigger names, not succeeded/aborted/preempted, which the patrol's states use),
    the machine leaves MONITORED_PATROL for the state given there (``SHUTDOWN``, ``DOCK_AT_STATION``, ...).
    """

    task: StateTask
    outcomes: Mapping[str, str] = field(default_factory=dict)

    @property
    def state(self) -> str:
        return self.task.state


def task_state_names(tasks: Sequence[Sequence[str]], n_poses: int) -> list[list[str]]:
    """The state names of the tasks at each pose: ``POSE_3_WAIT``, a repeated task gets ``_2``, ``_3``."""
    if tasks and len(tasks) != n_poses:
        raise ValueError(f"tasks are given for {len(tasks)} poses, the patrol has {n_poses}")
    names: list[list[str]] = []
    for i in range(n_poses):
        seen: dict[str, int] = {}
        row = []
        for suffix in (tasks[i] if tasks else ()):
            seen[suffix] = seen.get(suffix, 0) + 1
            row.append(f"{pose_state(i)}_{suffix}" + (f"_{seen[suffix]}" if seen[suffix] > 1 else ""))
        names.append(row)
    return names


def patrol_states(n_poses: int, tasks: Sequence[Sequence[str]] = (), monitors: Sequence[Monitor] = (),
                  first_pose: int = 0) -> list[dict[str, Any]]:
    """The state tree, with the name of the entry/exit callback of each state.

    ``tasks[i]`` are the state names (``WAIT``, ``DETECT``) of the tasks done at pose ``i``, in order;
    each ``monitors`` entry adds a region to MONITORED_PATROL.
    """
    if n_poses < 1:
        raise ValueError("a patrol needs at least one goal pose")
    poses: list[dict[str, Any]] = []
    for i, row in enumerate(task_state_names(tasks, n_poses)):
        poses.append({"name": pose_state(i), "on_enter": "start_patrol_goal", "on_exit": "stop_goal"})
        poses += [{"name": name, "on_enter": "start_task", "on_exit": "stop_task"} for name in row]
    added = [{"name": m.state, "on_enter": "start_task", "on_exit": "stop_task"} for m in monitors]
    return [
        {"name": "MONITORED_PATROL", "parallel": [
            {"name": "PATROL", "children": poses, "initial": pose_state(first_pose)},
            {"name": "ROBOT_BATTERY_MONITOR", "on_enter": "start_robot_battery_monitor",
             "on_exit": "stop_monitor"},
            *added,
        ]},
        {"name": "DOCK_AT_STATION", "initial": "MOVE_TO_STATION", "children": [
            {"name": "MOVE_TO_STATION", "on_enter": "start_move_to_station", "on_exit": "stop_goal"},
            {"name": "DOCK", "on_enter": "start_dock", "on_exit": "stop_action"},
        ]},
        {"name": "WAIT_UNTIL_CHARGED", "on_enter": "start_wait_until_charged", "on_exit": "stop_wait"},
        {"name": "UNDOCK", "on_enter": "start_undock", "on_exit": "stop_action"},
        {"name": "LOCALIZE", "on_enter": "start_localize", "on_exit": "stop_localize"},
        {"name": "SHUTDOWN", "on_enter": "shutdown", "final": True},
    ]


def _pose_transitions(n_poses: int, tasks: Sequence[Sequence[str]], first_pose: int,
                      stop_on_failure: bool) -> list[dict[str, Any]]:
    """Each pose's chain: the goal, then its tasks in order, then the next pose.

    ``aborted`` anywhere in the chain skips the rest of it (Nav2's waypoint follower goes on to the next
    waypoint), or ends the patrol with ``stop_on_failure``. The lap ends with the chain of the pose before
    ``first_pose``; there the lap limit is checked first.
    """
    lap_end = (first_pose - 1) % n_poses
    names = task_state_names(tasks, n_poses)
    table: list[dict[str, Any]] = []
    if not stop_on_failure and not any(names):  # the plain patrol, in its historical order
        table.append({"trigger": ["succeeded", "aborted"], "source": f"{PATROL}{SEP}{pose_state(lap_end)}",
                      "dest": SHUTDOWN, "conditions": "lap_limit_reached"})
        return table + [{"trigger": ["succeeded", "aborted"], "source": f"{PATROL}{SEP}{pose_state(i)}",
                         "dest": f"{PATROL}{SEP}{pose_state((i + 1) % n_poses)}"} for i in range(n_poses)]
    for i in range(n_poses):
        chain = [f"{PATROL}{SEP}{s}" for s in (pose_state(i), *names[i])]
        after = f"{PATROL}{SEP}{pose_state((i + 1) % n_poses)}"
        for k, state in enumerate(chain):
            last = k == len(chain) - 1
            ends = ["succeeded", "aborted"] if last else ["aborted"]
            if stop_on_failure:
                table.append({"trigger": "aborted", "source": state, "dest": SHUTDOWN,
                              "conditions": "stop_on_failure"})
            if i == lap_end:
                table.append({"trigger": ends, "source": state, "dest": SHUTDOWN, "conditions": "lap_limit_reached"})
            if not last:
                table.append({"trigger": "succeeded", "source": state, "dest": chain[k + 1]})
            table.append({"trigger": ends, "source": state, "dest": after})
    return table


def patrol_transitions(n_poses: int, tasks: Sequence[Sequence[str]] = (), first_pose: int = 0,
                       stop_on_failure: bool = False, monitors: Sequence[Monitor] = ()) -> list[dict[str, Any]]:
    """Every transition; the first one whose conditions hold is taken, as ``transitions`` does."""
    if not 0 <= first_pose < n_poses:
        raise ValueError(f"first pose {first_pose} is not one of the {n_poses} poses")
    table: list[dict[str, Any]] = [{"trigger": "start", "source": "initial", "dest": MONITORED_PATROL}]
    table += _pose_transitions(n_poses, tasks, first_pose, stop_on_failure)
    table += [
        {"trigger": "preempted", "source": PATROL, "dest": SHUTDOWN},
        {"trigger": "robot_battery_low", "source": ROBOT_MONITOR, "dest": DOCK_AT_STATION,
         "conditions": "has_station"},
        {"trigger": "robot_battery_low", "source": ROBOT_MONITOR, "dest": SHUTDOWN},
        {"trigger": "robot_battery_low", "source": LOCALIZE, "dest": DOCK_AT_STATION, "conditions": "has_station"},
        {"trigger": "robot_battery_low", "source": LOCALIZE, "dest": SHUTDOWN},
        *({"trigger": "robot_battery_empty", "source": s, "dest": SHUTDOWN}
          for s in (MONITORED_PATROL, *OUTSIDE_STATES)),
    ]
    for monitor in monitors:
        for trigger, dest in monitor.outcomes.items():
            if trigger in _BUILT_IN_TRIGGERS:
                raise ValueError(f"monitor {monitor.state}: outcome {trigger!r} is a trigger of the patrol's own "
                                 "states; give the monitor's outcome a word of its own")
            if dest not in MONITOR_DESTINATIONS:
                raise ValueError(f"monitor {monitor.state}: outcome {trigger!r} leads to {dest!r}, which is not "
                                 f"one of {', '.join(MONITOR_DESTINATIONS)}")
            table.append({"trigger": trigger, "source": f"{MONITORED_PATROL}{SEP}{monitor.state}", "dest": dest})
            table += [{"trigger": trigger, "source": s, "dest": dest} for s in OUTSIDE_STATES if s != dest]
    table += [
        {"trigger": "succeeded", "source": MOVE_TO_STATION, "dest": DOCK},
        {"trigger": "succeeded", "source": DOCK, "dest": WAIT_UNTIL_CHARGED},
        {"trigger": ["aborted", "preempted"], "source": DOCK_AT_STATION, "dest": SHUTDOWN},
        {"trigger": "charged", "source": WAIT_UNTIL_CHARGED, "dest": UNDOCK,
         "conditions": "resume_after_charging"},
        {"trigger": ["charged", "preempted"], "source": WAIT_UNTIL_CHARGED, "dest": SHUTDOWN},
        {"trigger": "succeeded", "source": UNDOCK, "dest": MONITORED_PATROL, "before": "prepare_resume"},
        {"trigger": ["aborted", "preempted"], "source": UNDOCK, "dest": SHUTDOWN},
        {"trigger": "localization_lost", "source": PATROL, "dest": LOCALIZE},
        {"trigger": "localized", "source": LOCALIZE, "dest": MONITORED_PATROL, "before": "prepare_resume"},
        {"trigger": ["aborted", "preempted"], "source": LOCALIZE, "dest": SHUTDOWN},
    ]
    # A list of triggers is shorthand for one transition per trigger, which is what transitions takes.
    return [{**t, "trigger": trig} for t in table
            for trig in (t["trigger"] if isinstance(t["trigger"], list) else [t["trigger"]])]


class _LoggedState(NestedState):
    """A nested state that reports entering and leaving, under its full dotted name."""

    separator = SEP

    def enter(self, event_data: Any) -> None:
        event_data.model.record("enter", self.name)
        super().enter(event_data)

    def exit(self, event_data: Any) -> None:
        event_data.model.record("exit", self.name)
        super().exit(event_data)


class _Machine(HierarchicalMachine):
    state_cls = _LoggedState


@dataclass
class PatrolStats:
    laps: int = 0
    goals_reached: int = 0
    goals_aborted: int = 0
    goals_preempted: int = 0
    results: list[tuple[str, str]] = field(default_factory=list)


class PatrolMachine:
    """The patrol, driving a robot: the built-in :class:`~navigation.simulation.Simulation` or a live one.

    ``sim`` is anything that keeps :class:`~navigation.robot_interface.PatrolRobot` (the attribute keeps its
    historical name: tasks and recorders that need the simulator's own parts reach them through it).

    ``tasks[i]`` are done at pose ``i`` after its goal is reached, each as a state of its own; ``monitors``
    run beside the robot battery monitor. ``first_pose`` is where PATROL starts (a lap ends with the pose before
    it); with ``stop_on_failure`` an aborted goal or task ends the patrol. ``camera`` returns a frame of the
    robot's camera for tasks that take pictures, and ``output_dir`` is where they save files.
    """

    def __init__(self, sim: PatrolRobot, goals: list[Pose2D] | tuple[Pose2D, ...], station_pose: Pose2D | None,
                 max_laps: int | None = None, resume_after_charging: bool = False,
                 monitor_period: float = 1.0, *, tasks: Sequence[Sequence[StateTask]] = (), first_pose: int = 0,
                 stop_on_failure: bool = False, monitors: Sequence[Monitor] = (),
                 camera: Callable[[], Any] | None = None, output_dir: str | Path | None = None) -> None:
        if not goals:
            raise ValueError("a patrol needs at least one goal pose")
        self.monitors = tuple(monitors)
        self.sim = sim
        self.goals = list(goals)
        self.station_pose = station_pose
        self.max_laps = max_laps
        self.resume = resume_after_charging
        self.monitor_period = monitor_period
        self.first_pose = first_pose
        self._stop_on_failure = stop_on_failure
        self.camera = camera
        self.output_dir = Path(output_dir) if output_dir is not None else None
        self.stats = PatrolStats()
        self.entered: list[str] = []
        self.outcome: str | None = None
        self.preempt_requested = False
        self.preempt_reason = ""
        self.state_listeners: list[Callable[[PatrolMachine], None]] = []
        self.entering = ""
        self.leaving = ""
        self._current_pose = 0
        self._resume_pose = 0
        self._token = 0
        self._unsubscribe: Callable[[], None] | None = None
        self._power_timer: TimerHandle | None = None
        self._wait_timer: TimerHandle | None = None
        self.end_reason = ""  # why the patrol ended by itself when that is not a preemption (LOCALIZE gave up)
        self.relocalize = Relocalize(sim)  # type: ignore[arg-type]
        n = len(self.goals)
        suffixes = [[t.state for t in row] for row in tasks]
        self.states_table = patrol_states(n, suffixes, self.monitors, first_pose)
        self.transitions_table = patrol_transitions(n, suffixes, first_pose, stop_on_failure, self.monitors)
        self.runner = TaskRunner(self, task_state_names(suffixes, n), tasks, self.monitors, PATROL + SEP,
                                 MONITORED_PATROL + SEP)
        self.machine = _Machine(
            model=self, states=copy.deepcopy(self.states_table), transitions=copy.deepcopy(self.transitions_table),
            initial="initial", auto_transitions=False, queued=True, send_event=True,
            ignore_invalid_triggers=True)

    @property
    def visits(self) -> list[Visit]:
        """Every visit to a pose so far, the open one last (see :class:`~navigation.tasks.Visit`)."""
        return self.runner.visits

    @property
    def visit_listeners(self) -> list[Callable[[Visit], None]]:
        """Called with each visit when it ends (the next pose, docking or SHUTDOWN)."""
        return self.runner.listeners

    def believed_pose(self) -> Pose2D:
        """Where the robot believes it is: what move_base drives on (the true pose without localisation)."""
        return self.sim.pose_estimate()

    # -- bookkeeping ----------------------------------------------------------------------------------
    def record(self, what: str, name: str) -> None:
        """Note a state entered or left; callbacks of the state read ``entering`` to know who they serve."""
        if name == "initial":
            return
        if what == "enter":
            self.entering = name
            self.entered.append(name)
        else:
            self.leaving = name
        self.sim.events.emit(f"state_{what}", state=name)
        if what == "enter":
            self.runner.entered(name)
        if name in OUTSIDE_STATES:  # the monitors keep watching here too (their regions are not active)
            for monitor in self.monitors:
                region = f"{MONITORED_PATROL}{SEP}{monitor.state}"
                if what == "enter":
                    self.runner.start(region)
                else:
                    self.runner.stop(region)
        if what == "enter":
            for listener in list(self.state_listeners):
                listener(self)

    @property
    def finished(self) -> bool:
        return self.outcome is not None

    def active_states(self) -> list[str]:
        """Every active state by full name, ancestors included (``MONITORED_PATROL`` and its regions)."""
        state = self.state  # type: ignore[attr-defined]
        leaves: list[str] = []

        def flatten(s: Any) -> None:
            if isinstance(s, list | tuple):
                for item in s:
                    flatten(item)
            else:
                leaves.append(str(s))

        flatten(state)
        active: list[str] = []
        for leaf in leaves:
            parts = leaf.split(SEP)
            for k in range(1, len(parts) + 1):
                name = SEP.join(parts[:k])
                if name not in active and name != "initial":
                    active.append(name)
        return active

    def _fire(self, trigger: str) -> None:
        """Fire a trigger at the end of this simulation step, never from inside a callback."""
        self.sim.clock.call_later(0.0, lambda: self.trigger(trigger))  # type: ignore[attr-defined]

    # -- conditions -----------------------------------------------------------------------------------
    def has_station(self, _event: Any = None) -> bool:
        return self.station_pose is not None and self.sim.dock_action is not None

    def resume_after_charging(self, _event: Any = None) -> bool:
        return self.resume

    def lap_limit_reached(self, _event: Any = None) -> bool:
        return self.max_laps is not None and self.stats.laps >= self.max_laps

    def stop_on_failure(self, _event: Any = None) -> bool:
        return self._stop_on_failure

    def pose_done(self, index: int) -> None:
        """Pose ``index`` is done (its goal aborted, or its last task ended): count a lap at the lap's end."""
        if index == (self.first_pose - 1) % len(self.goals):
            self.stats.laps += 1
            self.sim.events.emit("lap", laps=self.stats.laps)

    def prepare_resume(self, _event: Any = None) -> None:
        """Re-enter PATROL at the goal the low battery interrupted, not at POSE_0."""
        self.machine.get_state(PATROL).initial = pose_state(self._resume_pose)

    # -- running --------------------------------------------------------------------------------------
    def begin(self) -> None:
        """Enter MONITORED_PATROL (the machine is created in transitions' implicit ``initial`` state)."""
        self.machine.get_state(PATROL).initial = pose_state(self.first_pose)
        self.sim.events.subscribe(self._watch_localization)
        self.sim.events.subscribe(self._note_monitor_reason)
        self._power_timer = self.sim.clock.every(self.monitor_period, self._watch_power, first=0.0)
        self.trigger("start")  # type: ignore[attr-defined]

    def _watch_power(self) -> None:
        """In every state: a robot battery that is empty and not charging ends the run, named as such (its
        motors stopped; move_base would otherwise abort the goal as "no progress"); in LOCALIZE, where the
        robot battery monitor's region does not run, a low robot battery too."""
        if self.finished:
            return
        battery = self.sim.robot_battery
        # A live robot's battery view has only the percentage: empty is 0 % there, and it is never charging.
        empty = getattr(battery, "is_empty", battery.percentage <= 0.0)
        if empty and not getattr(battery, "charging", False):
            self.end_reason = "robot battery empty"
            self.sim.events.emit("robot_battery", event="EMPTY", percentage=round(battery.percentage, 2),
                                 state=self.entering)
            self.trigger("robot_battery_empty")  # type: ignore[attr-defined]
        elif battery.is_low and LOCALIZE in self.active_states():  # lost and low: dock (or stop) as in PATROL
            self.trigger("robot_battery_low")  # type: ignore[attr-defined]

    def _note_monitor_reason(self, ev: dict[str, Any]) -> None:
        """An added monitor whose result ends the run (its outcome leads to SHUTDOWN) gives the run its reason:
        the result's text, e.g. ``laptop battery low (19.9 %, not charging)``."""
        if ev["type"] != "task_result" or self.finished:
            return
        for monitor in self.monitors:
            if ev.get("state") == f"{MONITORED_PATROL}{SEP}{monitor.state}" and \
                    monitor.outcomes.get(ev.get("status", "")) == SHUTDOWN:
                self.end_reason = str(ev.get("text") or ev["status"])

    def request_preempt(self, reason: str = "preempted") -> None:
        """What Ctrl-C does: cancel whatever runs; every state entered from now on ends as preempted."""
        if self.finished or self.preempt_requested:
            return
        self.preempt_requested = True
        self.preempt_reason = reason
        self.sim.events.emit("preempt_requested", reason=reason)
        active = self.active_states()
        if self.sim.move_base.active:
            self.sim.move_base.cancel_goal(reason)
        elif self.sim.dock_action is not None and self.sim.dock_action.active:
            self.sim.dock_action.cancel()
        elif self.sim.undock_action.active:
            self.sim.undock_action.cancel()
        elif WAIT_UNTIL_CHARGED in active or LOCALIZE in active or any(s.startswith(PATROL + SEP) for s in active):
            self._fire("preempted")

    def _preempted_on_entry(self) -> bool:
        if self.preempt_requested:
            self._fire("preempted")
            return True
        return False

    # -- PATROL / MOVE_TO_STATION -----------------------------------------------------------------------
    def _send(self, pose: Pose2D, name: str, on_result: Callable[[GoalStatus, str], None]) -> None:
        self._token += 1
        token = self._token

        def deliver(status: GoalStatus, text: str) -> None:
            if token != self._token:
                log.debug("result %s of %s arrived after its state was left", status.value, name)
                return
            on_result(status, text)

        self.sim.move_base.send_goal(pose, deliver, name=name)

    def start_patrol_goal(self, _event: Any) -> None:
        index = int(self.entering.rsplit("_", 1)[1])
        self._current_pose = index
        self.runner.begin_visit(index, self.goals[index], pose_state(index), self.stats.laps + 1)
        if self._preempted_on_entry():
            return

        def on_result(status: GoalStatus, _text: str) -> None:
            st = self.stats
            st.results.append((pose_state(index), status.value))
            self.runner.goal_result(status.value, self.believed_pose())
            if status == GoalStatus.SUCCEEDED:
                st.goals_reached += 1
            elif status == GoalStatus.ABORTED:
                st.goals_aborted += 1
            else:
                st.goals_preempted += 1
            if status == GoalStatus.ABORTED or (status == GoalStatus.SUCCEEDED and not self.runner.has_tasks(index)):
                self.pose_done(index)
            self.trigger(RESULT_TRIGGER[status])  # type: ignore[attr-defined]

        self._send(self.goals[index], pose_state(index), on_result)

    def start_move_to_station(self, _event: Any) -> None:
        if self._preempted_on_entry():
            return
        assert self.station_pose is not None
        self._send(self.station_pose, "MOVE_TO_STATION",
                   lambda status, _t: self.trigger(RESULT_TRIGGER[status]))  # type: ignore[attr-defined]

    def stop_goal(self, _event: Any) -> None:
        """Leaving a goal state: forget its result and cancel the goal if it still runs."""
        self._token += 1
        if self.sim.move_base.active:
            goal = self.sim.move_base.goal
            if goal is not None and goal.name.startswith("POSE_"):
                self.stats.goals_preempted += 1
                self.stats.results.append((goal.name, GoalStatus.PREEMPTED.value))
            self.sim.move_base.cancel_goal("state left")

    # -- added states (tasks at poses, monitors) ----------------------------------------------------------
    def start_task(self, _event: Any) -> None:
        if self.runner.is_pose_task(self.entering) and self._preempted_on_entry():
            return
        self.runner.start(self.entering)

    def stop_task(self, _event: Any) -> None:
        self.runner.stop(self.leaving)

    # -- monitors -------------------------------------------------------------------------------------
    def start_robot_battery_monitor(self, _event: Any) -> None:
        battery = self.sim.robot_battery
        if battery.is_low:
            self._fire("robot_battery_low")

        def listen(ev: dict[str, Any]) -> None:
            if ev["type"] == "robot_battery" and ev["event"] in ("BATTERY_LOW", "BATTERY_CRITICAL"):
                self._fire("robot_battery_low")

        self._unsubscribe = self.sim.events.subscribe(listen)

    def stop_monitor(self, _event: Any) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None

    # -- docking and charging ---------------------------------------------------------------------------
    def start_dock(self, _event: Any) -> None:
        if self._preempted_on_entry():
            return
        self._token += 1
        token = self._token

        def deliver(status: GoalStatus, _text: str) -> None:
            if token == self._token:
                self.trigger(RESULT_TRIGGER[status])  # type: ignore[attr-defined]

        self.sim.start_dock(deliver)

    def start_undock(self, _event: Any) -> None:
        if self._preempted_on_entry():
            return
        self._resume_pose = self._current_pose
        self._token += 1
        token = self._token

        def deliver(status: GoalStatus, _text: str) -> None:
            if token == self._token:
                self.trigger(RESULT_TRIGGER[status])  # type: ignore[attr-defined]

        self.sim.start_undock(deliver)

    def stop_action(self, _event: Any) -> None:
        self._token += 1
        if self.sim.dock_action is not None and self.sim.dock_action.active:
            self.sim.dock_action.cancel()
        if self.sim.undock_action.active:
            self.sim.undock_action.cancel()

    def start_wait_until_charged(self, _event: Any) -> None:
        if self._preempted_on_entry():
            return

        def poll() -> None:
            if self.sim.robot_battery.is_full:
                if self._wait_timer is not None:
                    self._wait_timer.cancel()
                self.trigger("charged")  # type: ignore[attr-defined]

        self._wait_timer = self.sim.clock.every(self.monitor_period, poll, first=0.0)

    def stop_wait(self, _event: Any) -> None:
        if self._wait_timer is not None:
            self._wait_timer.cancel()
            self._wait_timer = None

    # -- LOCALIZE -------------------------------------------------------------------------------------
    def _watch_localization(self, ev: dict[str, Any]) -> None:
        if ev["type"] == "localization_lost" and not self.finished:
            self._fire("localization_lost")  # ignored outside PATROL: docking drives on the dock's own sensing

    def start_localize(self, _event: Any) -> None:
        self._resume_pose = self._current_pose
        if self._preempted_on_entry():
            return
        self._token += 1
        token = self._token

        def deliver(status: GoalStatus, text: str) -> None:
            if token != self._token:
                return
            if status == GoalStatus.SUCCEEDED:
                self._fire("localized")
            else:
                self.end_reason = text
                self._fire(RESULT_TRIGGER[status])

        self.relocalize.start(deliver)

    def stop_localize(self, _event: Any) -> None:
        self._token += 1
        self.relocalize.cancel()

    # -- SHUTDOWN -------------------------------------------------------------------------------------
    def shutdown(self, _event: Any) -> None:
        if self._power_timer is not None:
            self._power_timer.cancel()
            self._power_timer = None
        self.sim.halt()
        self.outcome = OUTCOME
        self.sim.events.emit("outcome", outcome=OUTCOME)
