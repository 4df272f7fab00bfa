"""Tasks at poses and added states: each task type, the registration API, monitors, the diagram, visits."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import cv2
import numpy as np
import pytest

from declare import Bool, Int, Str
from declare.fields import Value
from navigation.diagram import mermaid
from navigation.geometry import Pose2D, wrap_angle
from navigation.patrol import Monitor, PatrolMachine, patrol_transitions
from navigation.runner import run_patrol
from navigation.simulation import SimConfig, Simulation
from navigation.task_library import LookAroundTask, PhotoTask, WaitTask
from navigation.tasks import (
    PoseTask,
    StateTask,
    TaskContext,
    TaskSpecError,
    make_task,
    register_task,
    task_types,
    unregister_task,
)

STATION = Pose2D(14.4, 12.8, 0.0)
MP = "MONITORED_PATROL"
MP_ENTRY = [MP, f"{MP}.PATROL", f"{MP}.ROBOT_BATTERY_MONITOR"]


def st(name: str) -> str:
    return f"{MP}.PATROL.{name}"


def entered_at(machine: PatrolMachine, state: str) -> list[float]:
    return [e["t"] for e in machine.sim.events.of_type("state_enter") if e["state"] == state]


@pytest.fixture
def goals(b5203_poses) -> list[Pose2D]:
    return list(b5203_poses.goals[:3])


@pytest.fixture
def make_patrol(b5203_map):
    """A patrol on B5.2.03 starting at the station pose; machine options go to the machine, the rest to SimConfig."""
    machine_options = ("tasks", "first_pose", "stop_on_failure", "monitors", "camera", "output_dir", "max_laps")

    def build(goals: list[Pose2D], start: Pose2D = STATION, **options: Any) -> PatrolMachine:
        mine = {k: options.pop(k) for k in machine_options if k in options}
        sim = Simulation(b5203_map, start, replace(SimConfig(), **options))
        return PatrolMachine(sim, goals, None, **mine)

    return build


@dataclass
class FakeFrame:
    color: np.ndarray
    depth: np.ndarray
    yaw: float


def yaw_camera(machine_box: list[PatrolMachine]) -> Any:
    """A camera whose frames remember the robot's true heading, and show a gradient and a 2 m depth."""

    def grab() -> FakeFrame:
        color = np.zeros((48, 64, 3), np.uint8)
        color[..., 2] = np.arange(64, dtype=np.uint8)[None, :] * 4
        depth = np.full((48, 64), 2.0, np.float32)
        depth[0, 0] = np.nan
        return FakeFrame(color, depth, machine_box[0].sim.robot.yaw)

    return grab


def test_tasks_are_states_after_their_pose_in_order(make_patrol, goals):
    machine = make_patrol(goals, max_laps=1, tasks=[[WaitTask(seconds=3.0)], [],
                                                     [WaitTask(seconds=1.0), LookAroundTask(capture=False)]])
    summary = run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, st("POSE_0"), st("POSE_0_WAIT"), st("POSE_1"), st("POSE_2"),
                               st("POSE_2_WAIT"), st("POSE_2_LOOK_AROUND"), "SHUTDOWN"]
    assert (summary.laps, summary.goals_reached, summary.collisions) == (1, 3, 0)
    # The wait lasted its 3 s of simulated time.
    assert entered_at(machine, st("POSE_1"))[0] - entered_at(machine, st("POSE_0_WAIT"))[0] >= 3.0
    wait = [e for e in machine.sim.events.of_type("task_result") if e["state"] == st("POSE_0_WAIT")]
    assert wait[0]["status"] == "succeeded" and wait[0]["t"] - entered_at(machine, st("POSE_0_WAIT"))[0] == \
        pytest.approx(3.0, abs=0.11)
    # look_around ended facing the last heading, +40 deg from the goal's.
    assert abs(wrap_angle(machine.sim.robot.yaw - goals[2].yaw - math.radians(40))) < 0.04
    assert machine.sim.teleop is None and machine.sim.robot.w == 0.0
    laps = machine.sim.events.of_type("lap")
    assert len(laps) == 1 and laps[0]["t"] >= entered_at(machine, st("POSE_2_LOOK_AROUND"))[0]


@pytest.mark.parametrize("dt", [0.1, 1.0])
def test_look_around_takes_a_frame_at_each_heading(make_patrol, goals, dt):
    box: list[PatrolMachine] = []
    headings = [-90.0, 0.0, 120.0]
    seen: list[list[float]] = []
    machine = make_patrol(goals[:1], max_laps=1, dt=dt, camera=yaw_camera(box),
                          tasks=[[LookAroundTask(headings=tuple(headings))]])
    box.append(machine)
    machine.visit_listeners.append(lambda v: seen.append([c.frame.yaw for c in v.frames]))
    run_patrol(machine, handle_sigint=False)
    assert machine.entered[-2:] == [st("POSE_0_LOOK_AROUND"), "SHUTDOWN"]
    assert len(seen) == 1 and len(seen[0]) == 3
    for yaw, heading in zip(seen[0], headings, strict=True):
        assert abs(wrap_angle(yaw - goals[0].yaw - math.radians(heading))) < 0.035
    result = machine.sim.events.of_type("task_result")[-1]
    assert (result["status"], result["captures"]) == ("succeeded", 3)
    assert machine.visits[0].frames == []  # dropped once the visit ended
    assert result["t"] < 30.0  # three turns, not an oscillation


def test_photo_is_saved_as_png_with_depth_in_millimetres(make_patrol, goals, tmp_path):
    box: list[PatrolMachine] = []
    machine = make_patrol(goals[:2], max_laps=1, camera=yaw_camera(box), output_dir=tmp_path / "photos",
                          tasks=[[], [PhotoTask()]])
    box.append(machine)
    run_patrol(machine, handle_sigint=False)
    result = machine.sim.events.of_type("task_result")[0]
    assert result["status"] == "succeeded"
    assert result["files"] == ["visit002_POSE_1.png", "visit002_POSE_1_depth.png"]
    color = cv2.imread(str(tmp_path / "photos" / "visit002_POSE_1.png"), cv2.IMREAD_UNCHANGED)
    assert color.shape == (48, 64, 3) and color[5, 10, 2] == 40
    depth = cv2.imread(str(tmp_path / "photos" / "visit002_POSE_1_depth.png"), cv2.IMREAD_UNCHANGED)
    assert depth.dtype == np.uint16 and depth[1, 1] == 2000 and depth[0, 0] == 0


def test_a_failed_task_skips_to_the_next_pose(make_patrol, goals):
    machine = make_patrol(goals[:2], max_laps=1, tasks=[[PhotoTask(settle=0.0), WaitTask()], []])
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, st("POSE_0"), st("POSE_0_PHOTO"), st("POSE_1"), "SHUTDOWN"]
    result = machine.sim.events.of_type("task_result")[0]
    assert (result["status"], result["text"]) == ("aborted", "this patrol has no camera")
    assert [(t.kind, t.status) for t in machine.visits[0].tasks] == [("photo", "aborted")]


def test_stop_on_failure_ends_the_patrol(make_patrol, goals):
    machine = make_patrol(goals[:2], max_laps=3, stop_on_failure=True, tasks=[[PhotoTask(settle=0.0)], []])
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, st("POSE_0"), st("POSE_0_PHOTO"), "SHUTDOWN"]
    assert "POSE_0_PHOTO --> SHUTDOWN" not in mermaid(machine)
    assert "MONITORED_PATROL --> SHUTDOWN : aborted [stop_on_failure] from POSE_0_PHOTO" in mermaid(machine)


def test_first_pose_starts_there_and_ends_the_lap_before_it(make_patrol, goals):
    machine = make_patrol(goals, max_laps=1, first_pose=1, start=goals[0])
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, st("POSE_1"), st("POSE_2"), st("POSE_0"), "SHUTDOWN"]
    assert "[*] --> POSE_1" in mermaid(machine)
    with pytest.raises(ValueError, match="first pose 3"):
        patrol_transitions(3, first_pose=3)


def test_visits_record_goal_results_and_tasks(make_patrol, goals):
    machine = make_patrol(goals[:2], max_laps=2, tasks=[[WaitTask(seconds=0.5)], []])
    ended: list[int] = []
    machine.visit_listeners.append(lambda v: ended.append(v.number))
    run_patrol(machine, handle_sigint=False)
    assert [(v.number, v.name, v.lap, v.goal_status) for v in machine.visits] == [
        (1, "POSE_0", 1, "SUCCEEDED"), (2, "POSE_1", 1, "SUCCEEDED"), (3, "POSE_0", 2, "SUCCEEDED"),
        (4, "POSE_1", 2, "SUCCEEDED")]
    assert ended == [1, 2, 3, 4]
    assert [t.status for t in machine.visits[2].tasks] == ["succeeded"]
    assert all(v.ended is not None and v.arrived is not None for v in machine.visits)
    visit_events = machine.sim.events.of_type("visit")
    assert visit_events[0]["tasks"] == [["POSE_0_WAIT", "succeeded"]]


def test_preempting_during_a_task_stops_the_turn_and_shuts_down(make_patrol, goals):
    machine = make_patrol(goals[:1], tasks=[[LookAroundTask(headings=(170.0, -170.0), capture=False)]])
    machine.state_listeners.append(
        lambda m: m.sim.clock.call_later(0.5, lambda: m.request_preempt("test"))
        if m.entering.endswith("LOOK_AROUND") else None)
    run_patrol(machine, handle_sigint=False)
    assert machine.entered[-2:] == [st("POSE_0_LOOK_AROUND"), "SHUTDOWN"]
    result = machine.sim.events.of_type("task_result")[-1]
    assert (result["status"], result["text"]) == ("preempted", "state left")
    assert machine.sim.teleop is None and machine.sim.robot.w == 0.0


# -- the registration API -----------------------------------------------------------------------------
@register_task
class BeepTask(PoseTask):
    """A task of a test's own: counts its beeps into the visit, fails when asked to."""

    kind = "beep"
    state = "BEEP"
    options: ClassVar = {"times": Int(1, "beeps", min=1, max=10),
                         "fail": Bool(False, "fail instead"),
                         "tone": Value(Str("", "tone name"), default=None)}
    positional = "times"

    def start(self, ctx: TaskContext) -> None:
        if self.values["fail"]:
            raise RuntimeError("speaker broken")
        ctx.visit.data["beeps"] = ctx.visit.data.get("beeps", 0) + self.values["times"]
        ctx.emit("beep", times=self.values["times"])
        ctx.succeed(f"{self.values['times']} beeps")


@pytest.fixture(scope="module", autouse=True)
def forget_beep():
    """The test's own task type is registered at import, as a plug-in's would be, and removed afterwards."""
    yield
    unregister_task("beep")


def test_a_registered_task_is_built_from_mission_entries(tmp_path):
    assert {"wait", "photo", "look_around", "beep"} <= set(task_types())
    task = make_task({"beep": 3}, tmp_path)
    assert isinstance(task, BeepTask) and task.values["times"] == 3
    assert make_task("beep", tmp_path).values["times"] == 1
    assert isinstance(make_task({"look_around": [-30, 30]}, tmp_path), LookAroundTask)
    assert make_task({"wait": 2}, tmp_path).values["seconds"] == 2.0
    for item, message in [
        ({"beep": {"loud": 1}}, "beep.loud: unknown key (allowed: times, fail, tone)"),
        ({"beep": 11}, "beep.times: 11 is invalid: out of range, allowed int in 1..10"),
        ({"beep": 1.5}, "beep.times: 1.5 is invalid: expected an integer, got float"),
        ({"beep": {"fail": "yes"}}, "beep.fail: 'yes' is invalid: expected true or false, got str"),
        ({"look_around": {"headings": []}},
         "look_around.headings: [] is invalid: expected a non-empty list, each float in -360..360"),
        ({"wait": -1}, "wait.seconds: -1 is invalid: out of range, allowed float in 0..86400"),
        ({"wait": True}, "wait.seconds: True is invalid: expected a number, got bool"),
        ("dance", "'dance' is invalid: unknown task (known: "),
        ({"wait": 1, "beep": 2}, "expected a task name or a one-key mapping"),
        ({"photo": 3}, "photo: 3 is invalid: expected a mapping of settle, depth, got int"),
    ]:
        with pytest.raises(TaskSpecError) as info:
            make_task(item, tmp_path)
        assert message in str(info.value)


def test_register_task_refuses_incomplete_classes():
    class NoState(PoseTask):
        kind = "nostate"

        def start(self, ctx: TaskContext) -> None:
            ctx.succeed()

    with pytest.raises(TypeError, match="'kind' and 'state'"):
        register_task(NoState)
    NoState.state = "lower_case"
    with pytest.raises(TypeError, match="upper-case"):
        register_task(NoState)


def test_an_added_task_appears_in_the_event_log_and_the_diagram(make_patrol, goals, tmp_path):
    machine = make_patrol(goals[:2], max_laps=1,
                          tasks=[[make_task({"beep": 2}, tmp_path), make_task({"beep": 1}, tmp_path)],
                                 [make_task({"beep": {"fail": True}}, tmp_path), WaitTask()]])
    run_patrol(machine, handle_sigint=False)
    assert machine.entered == [*MP_ENTRY, st("POSE_0"), st("POSE_0_BEEP"), st("POSE_0_BEEP_2"), st("POSE_1"),
                               st("POSE_1_BEEP"), "SHUTDOWN"]
    beeps = machine.sim.events.of_type("beep")
    assert [(b["state"], b["visit"], b["pose"], b["times"]) for b in beeps] == [
        (st("POSE_0_BEEP"), 1, "POSE_0", 2), (st("POSE_0_BEEP_2"), 1, "POSE_0", 1)]
    assert machine.visits[0].data == {"beeps": 3}
    broken = machine.sim.events.of_type("task_result")[-1]
    assert (broken["status"], broken["text"]) == ("aborted", "error: RuntimeError: speaker broken")
    text = mermaid(machine, machine.active_states())
    for line in ["POSE_0 --> POSE_0_BEEP : succeeded", "POSE_0_BEEP --> POSE_0_BEEP_2 : succeeded",
                 "POSE_0_BEEP_2 --> POSE_1 : succeeded, aborted", "POSE_0 --> POSE_1 : aborted",
                 "POSE_1_BEEP --> POSE_1_WAIT : succeeded",
                 "MONITORED_PATROL --> SHUTDOWN : succeeded, aborted [lap_limit_reached] from POSE_1_WAIT",
                 "MONITORED_PATROL --> SHUTDOWN : aborted [lap_limit_reached] from POSE_1_BEEP",
                 "SHUTDOWN : ACTIVE"]:
        assert line in text


class Deadline(StateTask):
    """A monitor of a test's own: ends the patrol at a fixed simulated time."""

    state = "DEADLINE"

    def __init__(self, at: float) -> None:
        self.at = at
        self.cancelled = 0

    def start(self, ctx: TaskContext) -> None:
        ctx.after(self.at - ctx.now, lambda: ctx.finish("deadline_passed", f"t = {self.at:g} s"))

    def cancel(self, ctx: TaskContext) -> None:
        self.cancelled += 1


def test_an_added_monitor_runs_beside_the_patrol_and_ends_it(make_patrol, goals):
    deadline = Deadline(12.0)
    machine = make_patrol(goals, monitors=[Monitor(deadline, {"deadline_passed": "SHUTDOWN"})])
    run_patrol(machine, handle_sigint=False)
    assert machine.entered[:len(MP_ENTRY) + 1] == [*MP_ENTRY, f"{MP}.DEADLINE"]
    assert machine.entered[-1] == "SHUTDOWN"
    assert machine.sim.events.of_type("outcome")[0]["t"] == pytest.approx(12.0, abs=0.11)
    result = machine.sim.events.of_type("task_result")[0]
    assert (result["state"], result["status"], result["text"]) == (f"{MP}.DEADLINE", "deadline_passed", "t = 12 s")
    text = mermaid(machine)
    assert "        --\n        DEADLINE\n" in text
    assert "MONITORED_PATROL --> SHUTDOWN : deadline_passed from DEADLINE" in text
    assert deadline.cancelled == 0


def test_a_monitor_left_early_is_cancelled(make_patrol, goals):
    deadline = Deadline(1e6)
    machine = make_patrol(goals[:1], max_laps=1, monitors=[Monitor(deadline, {"deadline_passed": "SHUTDOWN"})])
    run_patrol(machine, handle_sigint=False)
    assert machine.entered[-1] == "SHUTDOWN" and deadline.cancelled == 1


@pytest.mark.parametrize(("outcomes", "message"), [
    ({"succeeded": "SHUTDOWN"}, "is a trigger of the patrol's own states"),
    ({"late": "PATROL"}, "leads to 'PATROL', which is not one of"),
])
def test_monitor_outcomes_are_checked(outcomes, message):
    with pytest.raises(ValueError, match=message):
        patrol_transitions(2, monitors=[Monitor(Deadline(1.0), outcomes)])


def test_tasks_for_the_wrong_number_of_poses_are_refused(make_patrol, goals):
    with pytest.raises(ValueError, match="tasks are given for 1 poses, the patrol has 3"):
        make_patrol(goals, tasks=[[WaitTask()]])


def test_the_plain_patrol_tables_are_unchanged(goals):
    """No tasks, first pose 0: exactly the transitions the patrol always had (the diagram in the docs)."""
    table = patrol_transitions(3)
    assert table[1] == {"trigger": "succeeded", "source": st("POSE_2"), "dest": "SHUTDOWN",
                        "conditions": "lap_limit_reached"}
    assert [t["dest"] for t in table[3:9]] == [st("POSE_1"), st("POSE_1"), st("POSE_2"), st("POSE_2"),
                                               st("POSE_0"), st("POSE_0")]


def test_built_in_task_options_are_documented():
    for cls in (WaitTask, PhotoTask, LookAroundTask):
        assert cls.summary and all(o.doc for o in cls.options.values())


def test_a_photo_without_an_output_folder_is_kept_for_the_next_task(make_patrol, goals):
    box: list[PatrolMachine] = []
    kept: list[int] = []
    machine = make_patrol(goals[:1], max_laps=1, camera=yaw_camera(box), tasks=[[PhotoTask(), WaitTask(seconds=0)]])
    box.append(machine)
    machine.visit_listeners.append(lambda v: kept.append(len(v.frames)))
    run_patrol(machine, handle_sigint=False)
    result = machine.sim.events.of_type("task_result")[0]
    assert (result["status"], result["text"], result["files"]) == ("succeeded", "taken, not saved (no output folder)",
                                                                    [])
    assert kept == [1] and machine.entered[-1] == "SHUTDOWN"


class LateBoomTask(PoseTask):
    """Fails in a timer's callback, as ``detect`` runs its work after settling."""

    kind = "late_boom"
    state = "LATE_BOOM"

    def start(self, ctx: TaskContext) -> None:
        ctx.after(0.5, self._explode)

    def _explode(self) -> None:
        raise RuntimeError("speaker broken")


def test_a_task_failing_in_its_delayed_callback_aborts_that_task_only(make_patrol, goals):
    machine = make_patrol(goals[:2], max_laps=1, tasks=[[LateBoomTask()], [WaitTask()]])
    run_patrol(machine, handle_sigint=False)
    results = [(r["task"], r["status"], r["text"]) for r in machine.sim.events.of_type("task_result")]
    assert ("late_boom", "aborted", "error: RuntimeError: speaker broken") in results
    assert ("wait", "succeeded") in [(task, status) for task, status, _ in results]  # the patrol went on
    assert machine.entered[-1] == "SHUTDOWN"


class CountingLookTask(PoseTask):
    """Takes ``n`` frames, then checks that the visit keeps them on disk and gives each back whole."""

    kind = "count_look"
    state = "COUNT_LOOK"
    seen: ClassVar[list[Any]] = []

    def start(self, ctx: TaskContext) -> None:
        for _ in range(20):
            ctx.capture("look")
        shots = list(ctx.visit.frames)
        CountingLookTask.seen = [(shot._frame is None, shot._file is not None and shot._file.is_file(),
                                  shot.frame.color.shape) for shot in shots]
        CountingLookTask.folder = shots[0]._file.parent
        ctx.succeed("looked")


def test_the_frames_of_a_visit_are_on_disk_until_it_ends(make_patrol, goals):
    box: list[PatrolMachine] = []
    machine = make_patrol(goals[:1], max_laps=1, tasks=[[CountingLookTask()]], camera=yaw_camera(box))
    box.append(machine)
    run_patrol(machine, handle_sigint=False)
    assert CountingLookTask.seen == [(True, True, (48, 64, 3))] * 20
    assert not CountingLookTask.folder.exists()  # removed when the visit ended
