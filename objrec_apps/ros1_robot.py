"""``objrec-patrol ... --robot ros1``: the patrol machine driving a live ROS 1 robot instead of the simulator.

The robot is reached through objrec's own ROS 1 transport (:mod:`objrec_ros.live`, no rospy): goals go to
move_base's action topics, the pose comes from amcl, the batteries from topics (or the laptop's own battery),
docking through the Kobuki's ``dock_drive_action``. The spec's options, all optional::

    --robot ros1,master=http://turtlebot:11311,pose=/amcl_pose,battery=/battery,dock=/dock_drive_action

=================  ==========================================================================================
``master``         the ROS master's URI (default ``ROS_MASTER_URI``, else http://localhost:11311)
``move_base``      move_base's action namespace (default ``/move_base``)
``pose``           the robot's pose, ``geometry_msgs/PoseWithCovarianceStamped`` (default ``/amcl_pose``)
``frame``          the frame of the goals (default ``map``)
``battery``        the robot's battery, ``sensor_msgs/BatteryState`` (default: none, the robot battery monitor
                   never fires)
``kobuki``         the robot's battery from the Kobuki's ``kobuki_msgs/SensorState`` (``/mobile_base/sensors/core``
                   on a TurtleBot 2), instead of ``battery``
``laptop``         the laptop's battery, ``sensor_msgs/BatteryState`` (default: this computer's battery)
``dock``           the docking action's namespace, ``kobuki_msgs/AutoDocking`` (default ``/dock_drive_action``;
                   ``none``: no docking, a low battery shuts the patrol down)
``timeout``        seconds to wait for move_base at the start (default 30)
``ack``            seconds a goal may wait for its server (move_base, the docking action) to name it in a status
                   or a result (default 5); then it ends ABORTED: the server did not acknowledge it
``silence``        seconds an acknowledged goal's server may say nothing on its status topic (default 10); then the
                   goal ends ABORTED: the server went silent
``first_message``  seconds for the first message of the pose and battery topics (default 10); then a warning and
                   a ``topic_silent`` event say which topic is quiet and what goes without it
=================  ==========================================================================================

Every network wait has a deadline (``timeout``, ``ack``, ``silence``, ``first_message``; the transport's own
calls have theirs): a goal that is never acknowledged ends ABORTED with the reason and the patrol goes on as for
a goal move_base aborted. Undocking is a move_base goal back to the station pose (the Kobuki has no undock
action). Times are wall-clock seconds since the robot was opened; the machine's timers, results and events run
on the patrol's thread, the transport's threads only hand messages over (:mod:`objrec_apps.ros1_clock`).
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

from navigation.events import EventLog
from navigation.geometry import Pose2D, yaw_from_quaternion
from navigation.robot_interface import BatteryView, ResultCallback, RobotReport
from navigation.robots import RobotError, RobotSetup, RobotUnavailable
from objrec_ros.live import LiveError, Transport, open_transport

from .ros1_actions import DEFAULT_ACK_SECONDS, DEFAULT_SILENCE_SECONDS, ActionClient
from .ros1_batteries import HostBattery, NoBattery, TopicBattery
from .ros1_clock import WallClock
from .ros1_feed import TopicFeed
from .ros1_goals import LiveDock, LiveMoveBase, UndockByGoal
from .ros1_messages import (
    AUTO_DOCKING_ACTION,
    BATTERY_STATE,
    MOVE_BASE_ACTION,
    POSE_WITH_COVARIANCE_STAMPED,
    SENSOR_STATE,
    patrol_typestore,
)

log = logging.getLogger(__name__)

#: How long one step waits for messages or a timer: the patrol notices Ctrl-C within it.
STEP_SECONDS = 0.05
DEFAULT_TIMEOUT = 30.0
DEFAULT_FIRST_MESSAGE = 10.0
NO_DOCK = ("", "none", "off")


class Ros1Robot:
    """A TurtleBot-class robot running move_base and amcl under ROS 1 (a :class:`PatrolRobot`)."""

    name: ClassVar[str] = "ros1"
    summary: ClassVar[str] = "a live ROS 1 robot: move_base, amcl, a battery topic and the Kobuki's docking"
    options: ClassVar[Mapping[str, str]] = {
        "master": "ROS master URI (default ROS_MASTER_URI)",
        "move_base": "move_base action namespace (default /move_base)",
        "pose": "pose topic, geometry_msgs/PoseWithCovarianceStamped (default /amcl_pose)",
        "frame": "frame of the goals (default map)",
        "battery": "robot battery topic, sensor_msgs/BatteryState (default none)",
        "kobuki": "robot battery from the Kobuki's kobuki_msgs/SensorState topic, e.g. /mobile_base/sensors/core",
        "laptop": "laptop battery topic, sensor_msgs/BatteryState (default this computer's battery)",
        "dock": "docking action namespace, kobuki_msgs/AutoDocking (default /dock_drive_action; none: no docking)",
        "timeout": "seconds to wait for move_base at the start (default 30)",
        "ack": f"seconds a goal may go unacknowledged by its server before it is aborted (default "
               f"{DEFAULT_ACK_SECONDS:g})",
        "silence": f"seconds a running goal's server may send no status before the goal is aborted (default "
                   f"{DEFAULT_SILENCE_SECONDS:g})",
        "first_message": f"seconds for the first pose and battery messages before a warning (default "
                         f"{DEFAULT_FIRST_MESSAGE:g})",
    }
    wall_clock = True

    @classmethod
    def open(cls, setup: RobotSetup, options: Mapping[str, str]) -> Ros1Robot:
        timeout = _seconds(options, "timeout", DEFAULT_TIMEOUT)
        for name, default in (("ack", DEFAULT_ACK_SECONDS), ("silence", DEFAULT_SILENCE_SECONDS),
                              ("first_message", DEFAULT_FIRST_MESSAGE)):
            _seconds(options, name, default)  # a bad value is one line before the master is contacted
        if options.get("battery") and options.get("kobuki"):
            raise RobotError("--robot ros1: battery= and kobuki= both name the robot's battery; give one")
        transport_options = {"master": options["master"]} if options.get("master") else {}
        try:
            transport = open_transport("ros1", transport_options, node_name="objrec_patrol")
        except LiveError as exc:
            raise RobotUnavailable(str(exc)) from None
        try:
            robot = cls(transport, setup, options)
            robot.wait_for_move_base(timeout, setup.stop_requested)
        except BaseException:
            transport.close()
            raise
        return robot

    def __init__(self, transport: Transport, setup: RobotSetup, options: Mapping[str, str]) -> None:
        self.transport = transport
        self.options = dict(options)
        self.clock = WallClock()
        self.events = EventLog(lambda: self.clock.now)
        self.start = setup.start
        self._pose = setup.start
        self._pose_updates = 0
        self.distance = 0.0
        self.trajectory: list[tuple[float, float, float, float]] = [(0.0, setup.start.x, setup.start.y,
                                                                     setup.start.yaw)]
        self.collision_points: list[tuple[float, float]] = []
        self.halted = False
        store = patrol_typestore()
        caller = f"/objrec_patrol_{os.getpid()}"
        deadlines = {"ack_seconds": _seconds(options, "ack", DEFAULT_ACK_SECONDS),
                     "silence_seconds": _seconds(options, "silence", DEFAULT_SILENCE_SECONDS)}
        self._watched: list[tuple[TopicFeed, str]] = []  # the topics whose first message has a deadline
        try:
            self._move_base_action = ActionClient(transport, options.get("move_base") or "/move_base",
                                                  MOVE_BASE_ACTION, store, self.clock, caller, "move_base",
                                                  **deadlines)
            self.move_base = LiveMoveBase(self._move_base_action, self.clock, self.events, self.pose_estimate,
                                          options.get("frame") or "map")
            self.pose_topic = options.get("pose") or "/amcl_pose"
            self._feeds = [TopicFeed(transport.subscribe(self.pose_topic, POSE_WITH_COVARIANCE_STAMPED, store),
                                     lambda raw: store.deserialize_ros1(raw, POSE_WITH_COVARIANCE_STAMPED),
                                     self._on_pose, self.clock)]
            self._watched.append((self._feeds[0], "the patrol keeps the start pose until one comes (amcl publishes "
                                                  "once it is given a pose or the robot moves): is amcl running?"))
            self.robot_battery: TopicBattery | NoBattery = NoBattery()
            if options.get("battery") or options.get("kobuki"):
                battery = TopicBattery(setup.config.robot_battery.low_percent, self.events)
                self.robot_battery = battery
                if options.get("battery"):
                    self._follow(options["battery"], BATTERY_STATE, battery.update)
                else:
                    self._follow(options["kobuki"], SENSOR_STATE, battery.update_kobuki)
                self._watched.append((self._feeds[-1], "the robot battery monitor cannot fire until one comes"))
            else:
                log.warning("--robot ros1: no battery= or kobuki= topic; the robot battery monitor will not fire")
            self.laptop_battery: BatteryView
            if options.get("laptop"):
                laptop = TopicBattery(setup.config.laptop_battery.low_percent, name="laptop_battery")
                self.laptop_battery = laptop
                self._follow(options["laptop"], BATTERY_STATE, laptop.update)
                self._watched.append((self._feeds[-1], "the laptop battery monitor cannot fire until one comes"))
            else:
                self.laptop_battery = HostBattery(setup.config.laptop_battery.low_percent)
            dock = options.get("dock", "/dock_drive_action")
            self._dock_action: ActionClient | None = None
            self._dock: LiveDock | None = None
            if dock.lower() not in NO_DOCK and setup.station_pose is not None:
                self._dock_action = ActionClient(transport, dock, AUTO_DOCKING_ACTION, store, self.clock, caller,
                                                 "the docking action", **deadlines)
                self._dock = LiveDock(self._dock_action, self.clock, self.events)
            self._undock = UndockByGoal(self.move_base, setup.station_pose, self.clock, self.events)
        except LiveError as exc:
            raise RobotUnavailable(str(exc)) from None
        first = _seconds(options, "first_message", DEFAULT_FIRST_MESSAGE)
        self.clock.call_later(first, lambda: self._check_first_messages(first))

    def _check_first_messages(self, seconds: float) -> None:
        """The deadline of the watched topics' first messages: each still quiet is a warning and a
        ``topic_silent`` event (not an error: a topic may start late, and the patrol can go on without it)."""
        for feed, without in self._watched:
            if feed.messages == 0:
                topic = feed.subscription.topic
                log.warning("--robot ros1: no message on %s within %g s: %s", topic, seconds, without)
                self.events.emit("topic_silent", topic=topic, seconds=seconds, text=without)

    def _follow(self, topic: str, msgtype: str, update: Any) -> None:
        store = patrol_typestore()
        self._feeds.append(TopicFeed(self.transport.subscribe(topic, msgtype, store),
                                     lambda raw: store.deserialize_ros1(raw, msgtype), update, self.clock))

    def wait_for_move_base(self, timeout: float, stop_requested: Callable[[], bool] = lambda: False) -> None:
        """Wait until move_base reports its status and listens to our goals (actionlib's wait_for_server);
        RobotUnavailable naming the namespace and the master after ``timeout`` s. A stop requested meanwhile
        (Ctrl-C) ends the wait at once: the patrol then starts preempted and sends no goal."""
        end = time.monotonic() + timeout
        while not self._move_base_action.connected:
            if stop_requested():
                log.info("stop requested while waiting for move_base")
                return
            if time.monotonic() >= end:
                action = self._move_base_action
                seen = "its status was seen but it does not take our goals" if action.server_seen else \
                    f"no status on {action.namespace}/status"
                raise RobotUnavailable(
                    f"move_base at {action.namespace} not seen within {timeout:g} s ({seen}; master "
                    f"{self.options.get('master') or os.environ.get('ROS_MASTER_URI', 'http://localhost:11311')}): "
                    "is move_base running, ROS_MASTER_URI right, and ROS_IP/ROS_HOSTNAME an address the robot "
                    "can reach?")
            self.clock.run_pending(STEP_SECONDS)

    # -- what the machine reads ---------------------------------------------------------------------------
    @property
    def dock_action(self) -> LiveDock | None:
        return self._dock

    @property
    def undock_action(self) -> UndockByGoal:
        return self._undock

    def pose_estimate(self) -> Pose2D:
        """The newest pose from the pose topic (the start pose until one arrives)."""
        return self._pose

    def _on_pose(self, message: Any) -> None:
        p = message.pose.pose
        q = p.orientation
        pose = Pose2D(float(p.position.x), float(p.position.y), yaw_from_quaternion(q.x, q.y, q.z, q.w))
        if self._pose_updates:
            self.distance += math.hypot(pose.x - self._pose.x, pose.y - self._pose.y)
        self._pose = pose
        self._pose_updates += 1
        self.trajectory.append((self.clock.now, pose.x, pose.y, pose.yaw))

    # -- what the machine does ----------------------------------------------------------------------------
    def start_dock(self, callback: ResultCallback | None) -> None:
        if self._dock is None:
            raise RuntimeError("this robot has no docking action")
        self.move_base.cancel_goal("docking")
        self._dock.start(callback)

    def start_undock(self, callback: ResultCallback | None) -> None:
        self._undock.start(callback)

    def halt(self) -> None:
        """SHUTDOWN: cancel move_base's goal and any docking; move_base stops the base when its goal ends."""
        self.move_base.cancel_goal("shutdown")
        if self._dock is not None:
            self._dock.cancel()
        self._undock.cancel()
        self.halted = True

    def step(self) -> None:
        self.clock.run_pending(STEP_SECONDS)

    def report(self) -> RobotReport:
        return RobotReport(distance=self.distance, localization=f"{self.pose_topic} ({self._pose_updates} poses)")

    def close(self) -> None:
        """Stop the feeds and leave the ROS system (publishers and subscriptions unregistered)."""
        for feed in self._feeds:
            feed.close()
        self._move_base_action.close()
        if self._dock_action is not None:
            self._dock_action.close()
        self.transport.close()


def _seconds(options: Mapping[str, str], name: str, default: float) -> float:
    """The option ``name`` in seconds (``default`` when not given); RobotError naming it when not in 0..3600."""
    text = options.get(name, "")
    if name not in options:
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 < value <= 3600:
        raise RobotError(f"--robot ros1: {name}={text!r} is invalid: expected seconds in 0..3600")
    return value
