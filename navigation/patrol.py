"""The patrol state machine, built with ``transitions``.

States and transitions are data (:func:`patrol_states`, :func:`patrol_transitions`); this module's
class only supplies what each state *does* when entered or left. Names and outcomes follow the ROS patrol's:

* ``MONITORED_PATROL`` (parallel) runs ``PATROL`` (``POSE_0``, ``POSE_1``, ... in a loop),
  ``ROBOT_BATTERY_MONITOR`` and ``LAPTOP_BATTERY_MONITOR``; the first to finish ends the other two,
  because leaving any region leaves the whole parallel state.
* ``robot_battery_low`` goes to ``DOCK_AT_STATION`` (``MOVE_TO_STATION`` then ``DOCK``) when a station
  is known, else to ``SHUTDOWN``; ``laptop_battery_low`` and ``preempted`` go to ``SHUTDOWN``.
* ``DOCK_AT_STATION`` succeeds into ``WAIT_UNTIL_CHARGED``, any failure goes to ``SHUTDOWN``.
* ``WAIT_UNTIL_CHARGED`` ends in ``SHUTDOWN`` when charged or preempted, or, with
  ``resume_after_charging``, goes through ``UNDOCK`` back to ``MONITORED_PATROL`` at the goal that was
  interrupted.
* ``SHUTDOWN`` stops the robot; the machine's outcome is then ``shutdown``.

Work is started on entry and cancelled on exit, and all waiting happens on the simulation clock.
A preemption request (Ctrl-C) is sticky, like smach's: the running action is cancelled, and any state
entered afterwards finishes at once with ``preempted``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from transitions.extensions.nesting import HierarchicalMachine, NestedState

from .clock import Timer
from .geometry import Pose2D
from .move_base import GoalStatus
from .simulation import Simulation

log = logging.getLogger(__name__)

SEP = "."
OUTCOME = "shutdown"

MONITORED_PATROL = "MONITORED_PATROL"
PATROL = f"{MONITORED_PATROL}{SEP}PATROL"
ROBOT_MONITOR = f"{MONITORED_PATROL}{SEP}ROBOT_BATTERY_MONITOR"
LAPTOP_MONITOR = f"{MONITORED_PATROL}{SEP}LAPTOP_BATTERY_MONITOR"
DOCK_AT_STATION = "DOCK_AT_STATION"
MOVE_TO_STATION = f"{DOCK_AT_STATION}{SEP}MOVE_TO_STATION"
DOCK = f"{DOCK_AT_STATION}{SEP}DOCK"
WAIT_UNTIL_CHARGED = "WAIT_UNTIL_CHARGED"
UNDOCK = "UNDOCK"
SHUTDOWN = "SHUTDOWN"

RESULT_TRIGGER = {GoalStatus.SUCCEEDED: "succeeded", GoalStatus.ABORTED: "aborted",
                  GoalStatus.PREEMPTED: "preempted"}


def pose_state(i: int) -> str:
    return f"POSE_{i}"


def patrol_states(n_poses: int) -> list[dict[str, Any]]:
    """The state tree, with the name of the entry/exit callback of each state."""
    if n_poses < 1:
        raise ValueError("a patrol needs at least one goal pose")
    poses = [{"name": pose_state(i), "on_enter": "start_patrol_goal", "on_exit": "stop_goal"}
             for i in range(n_poses)]
    return [
        {"name": "MONITORED_PATROL", "parallel": [
            {"name": "PATROL", "children": poses, "initial": pose_state(0)},
            {"name": "ROBOT_BATTERY_MONITOR", "on_enter": "start_robot_battery_monitor",
             "on_exit": "stop_monitor"},
            {"name": "LAPTOP_BATTERY_MONITOR", "on_enter": "start_laptop_battery_monitor",
             "on_exit": "stop_laptop_monitor"},
        ]},
        {"name": "DOCK_AT_STATION", "initial": "MOVE_TO_STATION", "children": [
            {"name": "MOVE_TO_STATION", "on_enter": "start_move_to_station", "on_exit": "stop_goal"},
            {"name": "DOCK", "on_enter": "start_dock", "on_exit": "stop_action"},
        ]},
        {"name": "WAIT_UNTIL_CHARGED", "on_enter": "start_wait_until_charged", "on_exit": "stop_wait"},
        {"name": "UNDOCK", "on_enter": "start_undock", "on_exit": "stop_action"},
        {"name": "SHUTDOWN", "on_enter": "shutdown", "final": True},
    ]


def patrol_transitions(n_poses: int) -> list[dict[str, Any]]:
    """Every transition; the first one whose conditions hold is taken, as ``transitions`` does."""
    last = n_poses - 1
    table: list[dict[str, Any]] = [{"trigger": "start", "source": "initial", "dest": MONITORED_PATROL}]
    table.append({"trigger": ["succeeded", "aborted"], "source": f"{PATROL}{SEP}{pose_state(last)}",
                  "dest": SHUTDOWN, "conditions": "lap_limit_reached"})
    table += [{"trigger": ["succeeded", "aborted"], "source": f"{PATROL}{SEP}{pose_state(i)}",
               "dest": f"{PATROL}{SEP}{pose_state((i + 1) % n_poses)}"} for i in range(n_poses)]
    table += [
        {"trigger": "preempted", "source": PATROL, "dest": SHUTDOWN},
        {"trigger": "robot_battery_low", "source": ROBOT_MONITOR, "dest": DOCK_AT_STATION,
         "conditions": "has_station"},
        {"trigger": "robot_battery_low", "source": ROBOT_MONITOR, "dest": SHUTDOWN},
        {"trigger": "laptop_battery_low", "source": LAPTOP_MONITOR, "dest": SHUTDOWN},
        {"trigger": "succeeded", "source": MOVE_TO_STATION, "dest": DOCK},
        {"trigger": "succeeded", "source": DOCK, "dest": WAIT_UNTIL_CHARGED},
        {"trigger": ["aborted", "preempted"], "source": DOCK_AT_STATION, "dest": SHUTDOWN},
        {"trigger": "charged", "source": WAIT_UNTIL_CHARGED, "dest": UNDOCK,
         "conditions": "resume_after_charging"},
        {"trigger": ["charged", "preempted"], "source": WAIT_UNTIL_CHARGED, "dest": SHUTDOWN},
        {"trigger": "succeeded", "source": UNDOCK, "dest": MONITORED_PATROL, "before": "prepare_resume"},
        {"trigger": ["aborted", "preempted"], "source": UNDOCK, "dest": SHUTDOWN},
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
    """The patrol, driving a :class:`~navigation.simulation.Simulation`."""

    def __init__(self, sim: Simulation, goals: list[Pose2D] | tuple[Pose2D, ...], station_pose: Pose2D | None,
                 max_laps: int | None = None, resume_after_charging: bool = False,
                 monitor_period: float = 1.0) -> None:
        if not goals:
            raise ValueError("a patrol needs at least one goal pose")
        self.sim = sim
        self.goals = list(goals)
        self.station_pose = station_pose
        self.max_laps = max_laps
        self.resume = resume_after_charging
        self.monitor_period = monitor_period
        self.stats = PatrolStats()
        self.entered: list[str] = []
        self.outcome: str | None = None
        self.preempt_requested = False
        self.preempt_reason = ""
        self.state_listeners: list[Callable[[PatrolMachine], None]] = []
        self.entering = ""
        self._current_pose = 0
        self._resume_pose = 0
        self._token = 0
        self._unsubscribe: Callable[[], None] | None = None
        self._laptop_timer: Timer | None = None
        self._wait_timer: Timer | None = None
        self.machine = _Machine(
            model=self, states=patrol_states(len(self.goals)), transitions=patrol_transitions(len(self.goals)),
            initial="initial", auto_transitions=False, queued=True, send_event=True,
            ignore_invalid_triggers=True)

    # -- bookkeeping ----------------------------------------------------------------------------------
    def record(self, what: str, name: str) -> None:
        """Note a state entered or left; callbacks of the state read ``entering`` to know who they serve."""
        if name == "initial":
            return
        if what == "enter":
            self.entering = name
            self.entered.append(name)
        self.sim.events.emit(f"state_{what}", state=name)
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

    def prepare_resume(self, _event: Any = None) -> None:
        """Re-enter PATROL at the goal the low battery interrupted, not at POSE_0."""
        self.machine.get_state(PATROL).initial = pose_state(self._resume_pose)

    # -- running --------------------------------------------------------------------------------------
    def begin(self) -> None:
        """Enter MONITORED_PATROL (the machine is created in transitions' implicit ``initial`` state)."""
        self.machine.get_state(PATROL).initial = pose_state(0)
        self.trigger("start")  # type: ignore[attr-defined]

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
        elif WAIT_UNTIL_CHARGED in active or any(s.startswith(PATROL + SEP) for s in active):
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
        if self._preempted_on_entry():
            return

        def on_result(status: GoalStatus, _text: str) -> None:
            st = self.stats
            st.results.append((pose_state(index), status.value))
            if status == GoalStatus.SUCCEEDED:
                st.goals_reached += 1
            elif status == GoalStatus.ABORTED:
                st.goals_aborted += 1
            else:
                st.goals_preempted += 1
            if status != GoalStatus.PREEMPTED and index == len(self.goals) - 1:
                st.laps += 1
                self.sim.events.emit("lap", laps=st.laps)
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

    def start_laptop_battery_monitor(self, _event: Any) -> None:
        def poll() -> None:
            if self.sim.laptop_battery.is_low:
                if self._laptop_timer is not None:
                    self._laptop_timer.cancel()
                self.trigger("laptop_battery_low")  # type: ignore[attr-defined]

        self._laptop_timer = self.sim.clock.every(self.monitor_period, poll, first=0.0)

    def stop_laptop_monitor(self, _event: Any) -> None:
        if self._laptop_timer is not None:
            self._laptop_timer.cancel()
            self._laptop_timer = None

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

    # -- SHUTDOWN -------------------------------------------------------------------------------------
    def shutdown(self, _event: Any) -> None:
        self.sim.halt()
        self.outcome = OUTCOME
        self.sim.events.emit("outcome", outcome=OUTCOME)
