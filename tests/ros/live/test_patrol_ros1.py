"""objrec-patrol --robot ros1: the patrol machine against a stand-in move_base written with rospy, on a real
ROS 1 master over loopback. The machine's events equal the simulator's for the same outcomes; the action
messages are Debian's (md5sums and bytes); the wall clock hands the transport's messages to the patrol's thread.
"""

from __future__ import annotations

import contextlib
import io
import json
import signal
import subprocess
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

import navigation
from navigation.battery import kobuki_percent
from navigation.cli import _percent as summary_percent
from navigation.cli import main
from navigation.events import EventLog
from navigation.geometry import Pose2D, quaternion_from_yaw
from navigation.move_base import GoalStatus
from navigation.poses import load_poses
from navigation.robot_interface import PatrolClock, PatrolRobot, machine_trace
from navigation.robots import ROBOTS
from objrec_apps import ros1_robot
from objrec_apps.ros1_actions import RESULT_GRACE_SECONDS, ActionClient
from objrec_apps.ros1_batteries import HostBattery, TopicBattery
from objrec_apps.ros1_clock import WallClock
from objrec_apps.ros1_messages import (
    GOAL_ID,
    GOAL_STATUS_ARRAY,
    MOVE_BASE_ACTION,
    SENSOR_STATE,
    action_types,
    patrol_typestore,
)
from objrec_apps.ros1_robot import Ros1Robot
from objrec_ros.msgdefs import message_from_dict
from tests.ros.live import ros1_env
from tests.ros.live.memory_transport import MemoryBus, MemoryTransport
from tests.ros.live.ros1_env import SYSTEM_PYTHON, Ros1Master, RospyNode, skip_without_ros1
from tests.signal_steps import signal_during

ros1_master = ros1_env.ros1_master  # the fixture, used by name

DATA = Path(navigation.__file__).parent / "data"
MAP = str(DATA / "b5203.yaml")
STAND_IN = Path(__file__).with_name("rospy_move_base.py")
LATE_STAND_IN = Path(__file__).with_name("rospy_late_move_base.py")
STATION = Pose2D(14.4, 12.8, 0.0)
SHIPPED = load_poses(DATA / "b5203.txt").goals
IN_TABLE = Pose2D(12.7, 12.2, 1.57)  # inside the central table: the simulator aborts it at once
GOALS = [SHIPPED[0], IN_TABLE, SHIPPED[2]]  # the stand-in is told to abort the second one too
#: Hang guard for a whole run on a loaded machine (never a timing assertion).
RUN_GUARD = 180.0

# The md5sums of kobuki_msgs' auto-docking action and sensor state as the kobuki_msgs package publishes them
# (rosserial's generated kobuki_msgs/AutoDockingActionGoal.h, AutoDockingActionResult.h, SensorState.h); Debian
# has no kobuki_msgs.
KOBUKI_MD5 = {"kobuki_msgs/msg/AutoDockingActionGoal": "4b30be6cd12b9e72826df56b481f40e0",
              "kobuki_msgs/msg/AutoDockingActionResult": "3fb2b9cd9cec6b4cb23b224521dd7679",
              "kobuki_msgs/msg/SensorState": "430a4bfd78449c8740bfef32b26613a6"}


@pytest.fixture
def ros1_robot_plugin():
    """``--robot ros1`` whether or not the ``objrec.robots`` entry point is installed yet."""
    with ROBOTS.replaced("ros1", Ros1Robot):
        yield


def write_poses(path: Path, goals: list[Pose2D], station: Pose2D | None) -> str:
    def line(p: Pose2D) -> str:
        qx, qy, qz, qw = quaternion_from_yaw(p.yaw)
        return f"{p.x}, {p.y}, 0.0, {qx}, {qy}, {qz}, {qw}"

    text = "".join(f"{line(g)}\n" for g in goals)
    if station is not None:
        text += f"station_pose: {line(station)}\n"
    path.write_text(text, encoding="utf-8")
    return str(path)


def read_events(path: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def summary_fields(text: str) -> dict[str, str]:
    return {k.strip(): v.strip() for k, v in (line.split(":", 1) for line in text.strip().splitlines())}


def run_patrol_command(args: list[str]) -> tuple[int, str, str]:
    """objrec-patrol in-process (the ros1 plug-in registered by the fixture), with its stdout and stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue(), err.getvalue()


def start_stand_in(master: Ros1Master, workdir: Path, *args: str, script: Path = STAND_IN,
                   name: str = "move_base_stand_in") -> RospyNode:
    """A rospy move_base stand-in (``script``) started and ready, or the test fails saying why."""
    node = RospyNode.start(script, master, workdir, args=list(args), name=name)
    if node.wait_for("ready") is None:
        node.stop()
        pytest.fail(f"the stand-in {name} did not start: {node.diagnostics()}")
    return node


def dock_definitions(workdir: Path) -> Path:
    """kobuki_msgs' auto-docking action definitions as our typestore has them, in workdir/kobuki (Debian has no
    kobuki_msgs: the stand-in generates its classes from these with genpy)."""
    definitions = workdir / "kobuki"
    definitions.mkdir()
    store = patrol_typestore()
    for name in ("AutoDockingActionGoal", "AutoDockingActionResult"):
        text = store.generate_msgdef(f"kobuki_msgs/msg/{name}", ros_version=1)[0]
        (definitions / f"{name}.msgdef").write_text(text, encoding="utf-8")
    return definitions


def stand_in_lines(node: RospyNode, kind: str, count: int) -> dict[str, list[list[str]]]:
    """The stand-in's printed lines (goal, cancel, result), split in words and grouped by kind, read until the
    ``count``-th line of ``kind``."""
    found: dict[str, list[list[str]]] = {"goal": [], "cancel": [], "result": []}
    while len(found[kind]) < count:
        line = node.line(RUN_GUARD)
        assert line is not None, f"the stand-in printed {found} but not {count} {kind} lines: {node.diagnostics()}"
        words = line.split()
        if words and words[0] in found:
            found[words[0]].append(words)
    return found


# -- the messages ---------------------------------------------------------------------------------------------
def test_action_messages_are_debians_move_base_msgs():
    """md5sums equal Debian's python3-move-base-msgs (rospy refuses a connection otherwise) and the bytes we
    write for a goal equal what rospy writes for the same goal."""
    skip_without_ros1()
    store = patrol_typestore()
    probe = """
import io, json
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult, MoveBaseActionFeedback, MoveBaseGoal
goal = MoveBaseActionGoal()
goal.header.stamp.secs, goal.header.stamp.nsecs = 1700000000, 250000000
goal.goal_id.id = "/objrec_patrol_1-1-1700000000.250"
goal.goal.target_pose.header.frame_id = "map"
goal.goal.target_pose.pose.position.x, goal.goal.target_pose.pose.position.y = 13.5, -2.25
goal.goal.target_pose.pose.orientation.z, goal.goal.target_pose.pose.orientation.w = 0.6, 0.8
buf = io.BytesIO(); goal.serialize(buf)
print(json.dumps({"md5": {c.__name__: c._md5sum for c in
                          (MoveBaseActionGoal, MoveBaseActionResult, MoveBaseActionFeedback, MoveBaseGoal)},
                  "goal": buf.getvalue().hex()}))
"""
    done = subprocess.run([SYSTEM_PYTHON, "-c", probe], capture_output=True, text=True, timeout=120, check=False,
                          env=ros1_env._base_env())
    assert done.returncode == 0, done.stderr
    debian = json.loads(done.stdout)
    for name, md5 in debian["md5"].items():
        assert store.generate_msgdef(f"move_base_msgs/msg/{name}", ros_version=1)[1] == md5, name
    ours = message_from_dict(store, "move_base_msgs/msg/MoveBaseActionGoal", {
        "header": {"stamp": {"sec": 1700000000, "nanosec": 250000000}},
        "goal_id": {"id": "/objrec_patrol_1-1-1700000000.250"},
        "goal": {"target_pose": {"header": {"frame_id": "map"},
                                 "pose": {"position": {"x": 13.5, "y": -2.25}, "orientation": {"z": 0.6, "w": 0.8}}}}})
    assert bytes(store.serialize_ros1(ours, "move_base_msgs/msg/MoveBaseActionGoal")).hex() == debian["goal"]


def test_kobuki_messages_have_kobukis_md5sums():
    store = patrol_typestore()
    for typename, md5 in KOBUKI_MD5.items():
        assert store.generate_msgdef(typename, ros_version=1)[1] == md5, typename


# -- the wall clock -------------------------------------------------------------------------------------------
def test_wall_clock_runs_posted_work_and_timers_on_the_calling_thread():
    clock = WallClock()
    assert isinstance(clock, PatrolClock)
    ran: list[tuple[str, int]] = []
    main = threading.get_ident()
    ticks = clock.every(0.01, lambda: ran.append(("tick", threading.get_ident())), first=0.0)
    clock.call_later(0.0, lambda: ran.append(("later", threading.get_ident())))
    posters = [threading.Thread(target=clock.post, args=(lambda i=i: ran.append((f"post{i}", threading.get_ident())),))
               for i in range(5)]
    for thread in posters:
        thread.start()
    for thread in posters:
        thread.join(timeout=60)
    rounds = 0
    while sum(1 for name, _ in ran if name == "tick") < 3:
        clock.run_pending(0.05)
        rounds += 1
        assert rounds < 10_000, "the periodic timer never fired three times"
    ticks.cancel()
    names = [name for name, _ in ran]
    assert sorted(n for n in names if n.startswith("post")) == [f"post{i}" for i in range(5)]
    assert names.count("later") == 1
    assert {ident for _, ident in ran} == {main}  # everything ran on the thread that called run_pending
    count = len(ran)
    clock.run_pending(0.0)
    assert len(ran) == count  # a cancelled timer never runs again


# -- the patrol -----------------------------------------------------------------------------------------------
def test_patrol_on_a_rospy_move_base_gives_the_simulators_events(ros1_master, ros1_robot_plugin, tmp_path):
    """One lap of three goals, the second aborted: by the simulator (it is inside the table) and by the
    stand-in (told to abort it). The machine's events are the same; the stand-in got our three goals."""
    poses = write_poses(tmp_path / "poses.txt", GOALS, STATION)
    code, out, err = run_patrol_command([poses, "--map", MAP, "--laps", "1", "--events", str(tmp_path / "sim.jsonl")])
    assert code == 0, err
    sim_fields = summary_fields(out)
    node = start_stand_in(ros1_master, tmp_path, "--abort", f"{IN_TABLE.x},{IN_TABLE.y}", "--delay", "0.3",
                          "--start", f"{STATION.x},{STATION.y},0")
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, "--laps", "1", "--events", str(tmp_path / "ros.jsonl"),
             "--render", str(tmp_path / "ros.png"), "--robot", f"ros1,master={ros1_master.uri},timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
        seen = stand_in_lines(node, "result", 3)
        goals, results = seen["goal"], seen["result"]
    finally:
        node.stop()
    sim_events, ros_events = read_events(tmp_path / "sim.jsonl"), read_events(tmp_path / "ros.jsonl")
    assert machine_trace(ros_events) == machine_trace(sim_events)
    assert [(e["name"], e["status"]) for e in ros_events if e["type"] == "goal_result"] == [
        ("POSE_0", "SUCCEEDED"), ("POSE_1", "ABORTED"), ("POSE_2", "SUCCEEDED")]
    # What move_base received: our goals, in order, each with its own id; its verdicts, in order.
    assert [float(v) for _, _, x, y in goals for v in (x, y)] == pytest.approx([v for g in GOALS for v in (g.x, g.y)],
                                                                                abs=1e-9)
    sent = [e for e in ros_events if e["type"] == "goal_sent"]
    assert [words[1] for words in goals] == [e["ros_id"] for e in sent]
    assert len({words[1] for words in goals}) == 3
    assert [int(words[2]) for words in results] == [3, 4, 3]  # actionlib's SUCCEEDED, ABORTED, SUCCEEDED
    fields = summary_fields(out)
    assert fields["goals"] == sim_fields["goals"] == "2 reached, 1 aborted, 0 preempted"
    assert fields["laps"] == "1" and fields["outcome"] == "shutdown"
    assert fields["time"].endswith("on the live robot")
    assert fields["localization"].startswith("from /amcl_pose (")
    assert (tmp_path / "ros.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # the path amcl reported, drawn
    # Each result carries the pose amcl (the stand-in) last published: the start or a goal reached by then.
    station, first, last = ((round(p.x, 4), round(p.y, 4)) for p in (STATION, GOALS[0], GOALS[2]))
    arrived = [(e["robot"]["x"], e["robot"]["y"]) for e in ros_events if e["type"] == "goal_result"]
    order = [station, first, last]
    assert arrived[0] in order[:2] and arrived[1] in order[:2] and arrived[2] in order, arrived
    steps = [order.index(place) for place in arrived]
    assert steps == sorted(steps), arrived  # the robot never went back where it had been
    # The patrol left the ROS system: no node of ours is registered at the master any more.
    assert not [n for n in ros1_master.nodes() if "objrec" in n]


def test_a_time_limit_cancels_the_running_goal_on_the_robot(ros1_master, ros1_robot_plugin, tmp_path):
    """Preemption (Ctrl-C or --time-limit, the same path) cancels move_base's goal over /move_base/cancel and
    ends in SHUTDOWN with the summary written."""
    poses = write_poses(tmp_path / "poses.txt", GOALS, None)
    node = start_stand_in(ros1_master, tmp_path, "--delay", "600", "--start", f"{GOALS[0].x},{GOALS[0].y},0")
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, "--time-limit", "1", "--events", str(tmp_path / "ros.jsonl"),
             "--robot", f"ros1,master={ros1_master.uri},timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
        seen = stand_in_lines(node, "cancel", 1)
        [goal], [cancel] = seen["goal"], seen["cancel"]
    finally:
        node.stop()
    assert cancel[1] == goal[1]
    trace = machine_trace(read_events(tmp_path / "ros.jsonl"))
    assert ("preempt_requested", "time limit") in trace
    assert ("goal_result", "POSE_0", "PREEMPTED") in trace
    assert trace[-2:] == [("state_enter", "SHUTDOWN"), ("outcome", "shutdown")]
    fields = summary_fields(out)
    assert fields["outcome"] == "shutdown (time limit)"
    assert fields["goals"] == "0 reached, 0 aborted, 1 preempted"
    assert fields["robot battery"] == "unknown"  # no battery= topic: never heard of, never low


@pytest.mark.parametrize("source", ["battery", "kobuki"])
def test_a_low_robot_battery_without_docking_shuts_down_as_in_the_simulator(ros1_master, ros1_robot_plugin,
                                                                          tmp_path, source):
    """The robot's battery below the threshold (a sensor_msgs/BatteryState topic, or the Kobuki's SensorState
    with the voltage in 0.1 V): robot_battery_low, no docking (dock=none), SHUTDOWN; the simulator started at
    the same low level and without a station gives the same machine events."""
    poses = write_poses(tmp_path / "poses.txt", GOALS, None)
    start = ["--start", str(STATION.x), str(STATION.y), "0"]
    code, _out, err = run_patrol_command([poses, "--map", MAP, *start, "--robot-battery", "20", "--events",
                                          str(tmp_path / "sim.jsonl")])
    assert code == 0, err
    extra: list[str] = []
    topic = "battery=/battery"
    if source == "kobuki":
        definitions = tmp_path / "kobuki"
        definitions.mkdir()
        (definitions / "SensorState.msgdef").write_text(
            patrol_typestore().generate_msgdef(SENSOR_STATE, ros_version=1)[0], encoding="utf-8")
        extra, topic = ["--kobuki", str(definitions)], "kobuki=/mobile_base/sensors/core"
    # The stand-in holds each goal long enough for the battery topic to be heard first (a hang guard, not a
    # timing assertion: the battery is published five times a second).
    node = start_stand_in(ros1_master, tmp_path, "--delay", "60", "--battery", "20", *extra,
                          "--start", f"{STATION.x},{STATION.y},0")
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, *start, "--events", str(tmp_path / "ros.jsonl"), "--time-limit", f"{RUN_GUARD:g}",
             "--robot", f"ros1,master={ros1_master.uri},{topic},dock=none,timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
    finally:
        node.stop()
    ros_events = read_events(tmp_path / "ros.jsonl")
    assert machine_trace(ros_events) == machine_trace(read_events(tmp_path / "sim.jsonl"))
    # Low from the first reading: the event fires once, whether the monitor was already listening or finds the
    # battery low when it starts (then the event came before the events file was opened, during start-up).
    assert [e["event"] for e in ros_events if e["type"] == "robot_battery"] in ([], ["BATTERY_LOW"])
    if source == "battery":
        assert summary_fields(out)["robot battery"] == "20.0 %"
    else:  # 20 % on the Kobuki's line is 13.72 V, sent as 137 (0.1 V), read back as the driver's 19.39 %
        assert summary_fields(out)["robot battery"] == f"{kobuki_percent(13.7):.1f} %" == "19.4 %"


def test_the_ros1_robot_keeps_the_protocol():
    assert Ros1Robot.wall_clock is True
    assert {"master", "pose", "battery", "kobuki", "dock", "move_base", "laptop", "frame", "timeout", "ack",
            "silence", "first_message"} == set(Ros1Robot.options)
    members = {name for name in dir(PatrolRobot) if not name.startswith("_")}
    assert members <= set(dir(Ros1Robot)) | {"clock", "events", "move_base", "robot_battery", "laptop_battery"}


def test_low_battery_docks_charges_undocks_and_resumes_as_in_the_simulator(ros1_master, ros1_robot_plugin,
                                                                           tmp_path):
    """The whole docking path on the robot: the battery topic drops while goal k runs, the patrol drives to the
    station, docks through /dock_drive_action (kobuki_msgs/AutoDocking, served by rospy with classes genpy
    generates from our definitions), waits until the battery is full, undocks and resumes at goal k. The
    simulator, whose battery runs low during the same goal, gives the same machine events; the robot's undock is
    a move_base goal (UNDOCK), which the simulator's undock action is not, so those two events are left out."""
    goals = list(SHIPPED[:4])
    poses = write_poses(tmp_path / "poses.txt", goals, STATION)
    common = [poses, "--map", MAP, "--laps", "1", "--resume-after-charging"]
    code, _out, err = run_patrol_command([*common, "--robot-battery", "28.2", "--events", str(tmp_path / "sim.jsonl")])
    assert code == 0, err
    sim_trace = machine_trace(read_events(tmp_path / "sim.jsonl"))
    [interrupted] = [t[1] for t in sim_trace if t[0] == "goal_result" and t[2] == "PREEMPTED"]
    k = int(str(interrupted).rsplit("_", 1)[1])
    definitions = dock_definitions(tmp_path)
    node = start_stand_in(ros1_master, tmp_path, "--delay", "1.5", "--battery", "100", "--low-at-goal", str(k + 1),
                          "--dock", str(definitions), "--start", f"{STATION.x},{STATION.y},0")
    try:
        code, out, err = run_patrol_command(
            [*common, "--events", str(tmp_path / "ros.jsonl"), "--time-limit", f"{RUN_GUARD:g}",  # a hang guard
             "--robot", f"ros1,master={ros1_master.uri},battery=/battery,timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
    finally:
        node.stop()
    ros_events = read_events(tmp_path / "ros.jsonl")
    undock_goal = (("goal_sent", "UNDOCK"), ("goal_result", "UNDOCK"))
    ros_trace = [t for t in machine_trace(ros_events) if t[:2] not in undock_goal]
    assert ros_trace == sim_trace
    assert ("action_result", "DockAction", "SUCCEEDED") in ros_trace
    assert ("state_enter", "UNDOCK") in ros_trace
    undock = [e for e in ros_events if e["type"] == "goal_sent" and e["name"] == "UNDOCK"]
    assert [(e["x"], e["y"]) for e in undock] == [(round(STATION.x, 4), round(STATION.y, 4))]
    fields = summary_fields(out)
    assert fields["goals"].startswith(f"{len(goals)} reached, 0 aborted, 1 preempted")
    assert fields["robot battery"] == "100.0 %"


def test_a_docking_driver_that_never_acknowledges_ends_the_patrol_in_shutdown(ros1_master, ros1_robot_plugin,
                                                                              tmp_path, caplog):
    """The battery runs low, the patrol drives to the station and sends the dock goal, but the docking driver
    holds its topics and never names the goal in a status (hung): after ack= seconds the dock goal ends ABORTED
    with the reason, a cancel is sent for it, and the patrol shuts down as after any failed docking, instead of
    waiting at the station for a verdict that never comes."""
    goals = list(SHIPPED[:4])
    poses = write_poses(tmp_path / "poses.txt", goals, STATION)
    node = start_stand_in(ros1_master, tmp_path, "--delay", "0.5", "--battery", "100", "--low-at-goal", "2",
                          "--dock", str(dock_definitions(tmp_path)), "--dock-hung")
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, "--laps", "1", "--resume-after-charging", "--events", str(tmp_path / "ros.jsonl"),
             "--time-limit", f"{RUN_GUARD:g}",  # a hang guard
             "--robot", f"ros1,master={ros1_master.uri},battery=/battery,ack=2,timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
        dock = node.wait_for("dock ", timeout=RUN_GUARD)
        cancel = node.wait_for("cancel ", timeout=RUN_GUARD)
    finally:
        node.stop()
    events = read_events(tmp_path / "ros.jsonl")
    reason = ("the docking action did not acknowledge the docking goal within 2 s: is the docking action running "
              "on /dock_drive_action?")
    [result] = [e for e in events if e["type"] == "action_result" and e["action"] == "DockAction"]
    assert (result["status"], result["text"]) == ("ABORTED", reason)
    assert dock is not None and cancel == f"cancel {dock.split()[1]}", node.diagnostics()  # the goal it gave up
    trace = machine_trace(events)
    assert ("state_enter", "SHUTDOWN") in trace
    assert ("state_enter", "WAIT_UNTIL_CHARGED") not in trace
    assert summary_fields(out)["outcome"] == "shutdown"
    assert reason in caplog.text


def test_genpy_computes_our_auto_docking_md5sums(ros1_master, tmp_path):
    """Debian has no kobuki_msgs; genpy, given our definitions, computes the same md5sums as we and kobuki do."""
    definitions = dock_definitions(tmp_path)
    node = RospyNode.start(STAND_IN, ros1_master, tmp_path, args=["--dock", str(definitions)], name="dock_stand_in")
    try:
        line = node.wait_for("genpy-md5 ", timeout=RUN_GUARD)  # printed before "ready"
    finally:
        node.stop()
    assert line is not None, node.diagnostics()
    assert line.split()[1:] == [KOBUKI_MD5["kobuki_msgs/msg/AutoDockingActionGoal"],
                                KOBUKI_MD5["kobuki_msgs/msg/AutoDockingActionResult"]]


@pytest.mark.parametrize(("robot", "needle"), [
    ("ros1,master=http://127.0.0.1:9,timeout=5", "127.0.0.1:9"),
    ("ros1,timeout=soon", "timeout='soon' is invalid: expected seconds in 0..3600"),
    ("ros1,ack=0", "ack='0' is invalid: expected seconds in 0..3600"),
    ("ros1,silence=-1", "silence='-1' is invalid: expected seconds in 0..3600"),
    ("ros1,first_message=never", "first_message='never' is invalid: expected seconds in 0..3600"),
    ("ros1,speed=3", "robot ros1 has no option speed (options: ack, battery, dock, first_message, frame, kobuki, "
                     "laptop, master, move_base, pose, silence, timeout)"),
    ("ros1,battery=/battery,kobuki=/mobile_base/sensors/core", "battery= and kobuki= both name the robot's battery"),
])
def test_a_robot_that_cannot_be_used_is_one_error_line(ros1_robot_plugin, tmp_path, robot, needle):
    """No master listening on the port, a bad option: one line naming it, exit code 2, nothing on stdout."""
    poses = write_poses(tmp_path / "poses.txt", GOALS, None)
    code, out, err = run_patrol_command([poses, "--map", MAP, "--laps", "1", "--robot", robot])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("objrec-patrol: error: ") and needle in err, err


def test_ctrl_c_while_waiting_for_move_base_shuts_down_without_a_goal(ros1_master, ros1_robot_plugin, tmp_path,
                                                                      monkeypatch):
    """A real SIGINT during start-up (no move_base on the master, so the robot is still waiting for it): the
    wait ends, the patrol starts preempted and shuts down without sending a goal, summary and events written."""
    signal_during(monkeypatch, ros1_robot, "LiveMoveBase", signal.SIGINT)  # built just before the wait
    poses = write_poses(tmp_path / "poses.txt", GOALS, None)
    code, out, err = run_patrol_command(
        [poses, "--map", MAP, "--events", str(tmp_path / "ros.jsonl"),
         "--robot", f"ros1,master={ros1_master.uri},timeout={RUN_GUARD:g}"])
    assert code == 0, err
    assert summary_fields(out)["outcome"] == "shutdown (SIGINT)"
    trace = machine_trace(read_events(tmp_path / "ros.jsonl"))
    assert not [t for t in trace if t[0] == "goal_sent"]
    assert trace[0] == ("preempt_requested", "SIGINT") and trace[-1] == ("outcome", "shutdown")


# -- the batteries --------------------------------------------------------------------------------------------
def test_the_laptop_battery_is_read_from_power_supply_files(tmp_path):
    supply = tmp_path / "power_supply"
    (supply / "AC").mkdir(parents=True)
    (supply / "AC" / "type").write_text("Mains\n")
    assert HostBattery(20.0, supply).is_low is False  # no battery at all: never low
    assert summary_percent(HostBattery(20.0, supply).percentage) == "unknown"
    battery_dir = supply / "BAT0"
    battery_dir.mkdir()
    (battery_dir / "type").write_text("Battery\n")
    (battery_dir / "capacity").write_text("15\n")
    (battery_dir / "status").write_text("Discharging\n")
    laptop = HostBattery(20.0, supply)
    assert (laptop.percentage, laptop.is_low) == (15.0, True)
    (battery_dir / "status").write_text("Charging\n")
    assert HostBattery(20.0, supply).is_low is False  # low but charging, as the simulator's laptop


def test_a_battery_state_in_fractions_or_percent_and_its_events():
    events = EventLog(lambda: 0.0)
    battery = TopicBattery(28.0, events)
    assert battery.is_low is False and battery.is_full is False  # nothing heard yet
    starts_low = TopicBattery(28.0, events)
    starts_low.update(SimpleNamespace(percentage=0.2, voltage=14.5, power_supply_status=2))
    assert starts_low.is_low  # from unknown to low is a crossing: the event fires, once
    assert [e["event"] for e in events.of_type("robot_battery")] == ["BATTERY_LOW"]
    events.events.clear()
    message = SimpleNamespace(percentage=0.5, voltage=15.5, power_supply_status=2)
    battery.update(message)
    assert (battery.percentage, battery.is_low) == (50.0, False)
    for pct in (27.0, 26.0, 29.0, 31.0, 27.5):  # crosses down, stays, re-arms only 2 % above the threshold
        battery.update(SimpleNamespace(percentage=pct, voltage=14.0, power_supply_status=2))
    assert [e["event"] for e in events.of_type("robot_battery")] == ["BATTERY_LOW", "BATTERY_LOW"]
    battery.update(SimpleNamespace(percentage=1.0, voltage=16.5, power_supply_status=4))
    assert battery.is_full and battery.percentage == 100.0
    battery.update(SimpleNamespace(percentage=float("nan"), voltage=0.0, power_supply_status=0))
    assert battery.percentage == 100.0  # a driver that does not know keeps the last level


# -- every wait has a deadline --------------------------------------------------------------------------------
def start_late_stand_in(master: Ros1Master, workdir: Path, *args: str) -> RospyNode:
    return start_stand_in(master, workdir, *args, script=LATE_STAND_IN, name="late_move_base")


def unacknowledged(number: int, seconds: str = "1") -> str:
    return (f"move_base did not acknowledge goal {number} (POSE_{number - 1}) within {seconds} s: is move_base "
            "running on /move_base?")


def test_goals_move_base_never_acknowledges_end_aborted_and_the_patrol_goes_on(ros1_master, ros1_robot_plugin,
                                                                                tmp_path, caplog):
    """A move_base that holds the topics but never names a goal in a status (hung): each goal ends ABORTED after
    ack= seconds with the reason, a cancel is sent for it, and the patrol goes on exactly as the simulator's does
    when every goal is aborted (three goals inside the table). The pose topic stays quiet: after first_message=
    seconds a warning and a topic_silent event say so."""
    in_table = [IN_TABLE, Pose2D(IN_TABLE.x + 0.1, IN_TABLE.y, 0.0), Pose2D(IN_TABLE.x, IN_TABLE.y + 0.1, 0.0)]
    poses = write_poses(tmp_path / "poses.txt", in_table, None)
    start = ["--start", str(SHIPPED[0].x), str(SHIPPED[0].y), "0"]
    code, out, err = run_patrol_command([poses, "--map", MAP, *start, "--laps", "1", "--events",
                                         str(tmp_path / "sim.jsonl")])
    assert code == 0, err
    assert summary_fields(out)["goals"] == "0 reached, 3 aborted, 0 preempted"
    node = start_late_stand_in(ros1_master, tmp_path, "--late-goals", "99", "--late-by", "never")
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, *start, "--laps", "1", "--events", str(tmp_path / "ros.jsonl"),
             "--time-limit", f"{RUN_GUARD:g}",  # a hang guard
             "--robot", f"ros1,master={ros1_master.uri},ack=1,first_message=1,timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
        lines = node.lines_until(6, RUN_GUARD)
    finally:
        node.stop()
    ros_events = read_events(tmp_path / "ros.jsonl")
    assert machine_trace(ros_events) == machine_trace(read_events(tmp_path / "sim.jsonl"))
    assert [(e["status"], e["text"]) for e in ros_events if e["type"] == "goal_result"] == [
        ("ABORTED", unacknowledged(k)) for k in (1, 2, 3)]
    sent = [str(e["ros_id"]) for e in ros_events if e["type"] == "goal_sent"]
    assert sorted(lines) == sorted([f"goal {i}" for i in sent] + [f"cancel {i}" for i in sent])  # none taken
    assert summary_fields(out)["goals"] == "0 reached, 3 aborted, 0 preempted"
    assert summary_fields(out)["outcome"] == "shutdown"
    [silent] = [e for e in ros_events if e["type"] == "topic_silent"]
    assert (silent["topic"], silent["seconds"]) == ("/amcl_pose", 1.0)
    assert "no message on /amcl_pose within 1 s: the patrol keeps the start pose" in caplog.text
    assert unacknowledged(3) in caplog.text  # each give-up is a warning as well as an event


@pytest.mark.parametrize(("late_by", "ack", "statuses"), [
    ("3", "1", ["ABORTED", "SUCCEEDED", "SUCCEEDED"]),  # later than the deadline: given up, then recalled
    ("1", "4", ["SUCCEEDED", "SUCCEEDED", "SUCCEEDED"]),  # late but within it: waited for
])
def test_a_goal_acknowledged_late(ros1_master, ros1_robot_plugin, tmp_path, late_by, ack, statuses):
    """move_base takes the first goal ``late_by`` seconds after it came. Past the ack= deadline the patrol has
    given it up (ABORTED with the reason, a cancel sent) and drives to the next goal; the late server finds the
    cancel and recalls the goal, and its late verdict does not reach the patrol. Within the deadline the goal is
    simply waited for."""
    goals = list(SHIPPED[:3])
    poses = write_poses(tmp_path / "poses.txt", goals, None)
    node = start_late_stand_in(ros1_master, tmp_path, "--late-goals", "1", "--late-by", late_by)
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, "--laps", "1", "--events", str(tmp_path / "ros.jsonl"), "--time-limit",
             f"{RUN_GUARD:g}", "--robot", f"ros1,master={ros1_master.uri},ack={ack},timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
        recalled = node.wait_for("recalled ", timeout=RUN_GUARD) if statuses[0] == "ABORTED" else None
    finally:
        node.stop()
    ros_events = read_events(tmp_path / "ros.jsonl")
    results = [e for e in ros_events if e["type"] == "goal_result"]
    assert [e["status"] for e in results] == statuses
    first = next(e for e in ros_events if e["type"] == "goal_sent")
    if statuses[0] == "ABORTED":
        assert results[0]["text"] == unacknowledged(1)
        assert recalled == f"recalled {first['ros_id']}", node.diagnostics()
    else:
        assert results[0]["text"] == "goal reached"
    reached = statuses.count("SUCCEEDED")
    assert summary_fields(out)["goals"] == f"{reached} reached, {3 - reached} aborted, 0 preempted"


def test_a_move_base_that_falls_silent_mid_goal_aborts_it(ros1_master, ros1_robot_plugin, tmp_path):
    """move_base acknowledges the first goal, then publishes nothing more (hung): that goal ends ABORTED after
    silence= seconds without a status, and the next ones, never named in a status, after ack= seconds each."""
    poses = write_poses(tmp_path / "poses.txt", list(SHIPPED[:3]), None)
    node = start_late_stand_in(ros1_master, tmp_path, "--mute-after", "1", "--delay", "600")
    try:
        code, out, err = run_patrol_command(
            [poses, "--map", MAP, "--laps", "1", "--events", str(tmp_path / "ros.jsonl"), "--time-limit",
             f"{RUN_GUARD:g}", "--robot", f"ros1,master={ros1_master.uri},ack=1,silence=2,timeout={RUN_GUARD:g}"])
        assert code == 0, err + node.diagnostics()
    finally:
        node.stop()
    results = [(e["status"], e["text"]) for e in read_events(tmp_path / "ros.jsonl") if e["type"] == "goal_result"]
    assert results == [
        ("ABORTED", "move_base went silent: no status on /move_base/status for 2 s while goal 1 (POSE_0) ran: is "
                    "move_base still running?"),
        ("ABORTED", unacknowledged(2)), ("ABORTED", unacknowledged(3))]
    assert summary_fields(out)["goals"] == "0 reached, 3 aborted, 0 preempted"


def in_process_move_base(name: str, **deadlines: float):  # type: ignore[no-untyped-def]
    """No ROS: an action client for /move_base on the in-process bus, on a clock whose time the test sets
    (``now[0]``); ``send(label)`` sends a goal whose end is appended to ``ended`` as (label, status, text).
    Returns (bus, transport, store, now, clock, action, ended, send)."""
    bus = MemoryBus()
    MemoryTransport.bus = bus
    transport = MemoryTransport({}, name)
    store = patrol_typestore()
    now = [0.0]
    clock = WallClock(monotonic=lambda: now[0])
    action = ActionClient(transport, "/move_base", MOVE_BASE_ACTION, store, clock, "/t", "move_base", **deadlines)
    ended: list[tuple[str, GoalStatus, str]] = []

    def send(label: str) -> str:
        return action.send({"target_pose": {"header": {"frame_id": "map"}}},
                           lambda s, t: ended.append((label, s, t)), label)

    return bus, transport, store, now, clock, action, ended, send


def test_the_action_clients_deadlines_on_a_clock_that_is_told_the_time():
    """No ROS: the action client on the in-process bus, its clock's time set by the test. A goal no status names
    is given up after ack seconds (ABORTED with the reason, a cancel published); a goal a status names is not,
    and is given up only when the status then stays quiet for silence seconds; a status that keeps coming keeps
    it running."""
    bus, transport, store, now, clock, action, ended, send = in_process_move_base(
        "deadlines", ack_seconds=5.0, silence_seconds=10.0)
    status_out = transport.advertise("/move_base/status", GOAL_STATUS_ARRAY, store)

    def status(*goal_ids: str) -> None:
        """Publish a status naming ``goal_ids`` as ACTIVE and wait (a hang guard) until the client has it."""
        before = action.statuses
        message = message_from_dict(store, GOAL_STATUS_ARRAY, {
            "status_list": [{"goal_id": {"id": i}, "status": 1} for i in goal_ids]})
        status_out.publish(bytes(store.serialize_ros1(message, GOAL_STATUS_ARRAY)))
        for _ in range(2000):
            clock.run_pending(0.01)
            if action.statuses > before:
                return
        pytest.fail("the status never reached the client")

    try:
        never = send("goal 1 (POSE_0)")
        now[0] = 4.9
        clock.run_pending(0.0)
        assert ended == []
        now[0] = 5.0
        clock.run_pending(0.0)
        assert ended == [("goal 1 (POSE_0)", GoalStatus.ABORTED, "move_base did not acknowledge goal 1 (POSE_0) "
                                                                 "within 5 s: is move_base running on /move_base?")]
        cancels = [store.deserialize_ros1(m.raw, GOAL_ID).id for m in bus.sent.get("/move_base/cancel", [])]
        assert cancels == [never]
        ended.clear()
        taken = send("goal 2 (POSE_1)")
        status(taken)
        for t in (6.0, 10.0, 14.0, 17.0):  # the status keeps coming: no deadline passes
            now[0] = t
            status(taken)
        now[0] = 26.9
        clock.run_pending(0.0)
        assert ended == []
        now[0] = 27.25  # 10 s after the last status, at the next silence check
        clock.run_pending(0.0)
        assert ended == [("goal 2 (POSE_1)", GoalStatus.ABORTED, "move_base went silent: no status on "
                                                                 "/move_base/status for 10 s while goal 2 (POSE_1) "
                                                                 "ran: is move_base still running?")]
        assert clock.next_due() is None  # no goal left: no timer left
    finally:
        action.close()
        transport.close()


def test_a_terminal_status_waits_for_its_result_which_carries_the_servers_text():
    """No ROS: the status array (10 Hz) may overtake a goal's result, and only the result carries the server's
    text. A goal whose status turns SUCCEEDED ends on its result when that follows within
    ``RESULT_GRACE_SECONDS``; a goal whose result never comes ends on the status alone after that grace."""
    _bus, transport, store, now, clock, action, ended, send = in_process_move_base("grace")
    status_out = transport.advertise("/move_base/status", GOAL_STATUS_ARRAY, store)
    result_type = action_types(MOVE_BASE_ACTION)[1]
    result_out = transport.advertise("/move_base/result", result_type, store)

    def publish(out, msgtype: str, data: dict, counter) -> None:  # type: ignore[no-untyped-def]
        """Publish ``data`` and run the clock (a hang guard) until ``counter()`` says the client handled it."""
        before = counter()
        out.publish(bytes(store.serialize_ros1(message_from_dict(store, msgtype, data), msgtype)))
        for _ in range(2000):
            clock.run_pending(0.01)
            if counter() > before:
                return
        pytest.fail(f"the {msgtype} never reached the client")

    try:
        first = send("goal 1 (POSE_0)")
        publish(status_out, GOAL_STATUS_ARRAY, {"status_list": [{"goal_id": {"id": first}, "status": 3}]},
                lambda: action.statuses)
        assert ended == []  # a terminal status alone: the result may follow
        now[0] = 0.3
        publish(result_out, result_type, {"status": {"goal_id": {"id": first}, "status": 3, "text": "goal reached"}},
                lambda: len(ended))  # the result ends the goal
        assert ended == [("goal 1 (POSE_0)", GoalStatus.SUCCEEDED, "goal reached")]
        ended.clear()
        second = send("goal 2 (POSE_1)")
        publish(status_out, GOAL_STATUS_ARRAY, {"status_list": [{"goal_id": {"id": second}, "status": 3}]},
                lambda: action.statuses)
        now[0] = 0.3 + RESULT_GRACE_SECONDS - 0.01
        clock.run_pending(0.0)
        assert ended == []
        now[0] = 0.3 + RESULT_GRACE_SECONDS + 0.01
        clock.run_pending(0.0)
        assert ended == [("goal 2 (POSE_1)", GoalStatus.SUCCEEDED, "succeeded (/move_base)")]  # the result was lost
    finally:
        action.close()
        transport.close()
