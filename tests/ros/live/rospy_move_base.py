#!/usr/bin/env python3
"""A stand-in move_base, amcl, battery and Kobuki docking written with rospy, for the live patrol tests (run by
Debian's /usr/bin/python3).

It speaks move_base's action topics as actionlib's server does, without actionlib: goals on /move_base/goal,
cancels on /move_base/cancel, every goal's status on /move_base/status (10 Hz, finished ones kept 5 s) and one
result per goal on /move_base/result. A goal succeeds ``--delay`` seconds after it arrives, and the robot is
then at the goal (published on /amcl_pose, 5 Hz); a goal within 0.05 m of an ``--abort X,Y`` point is aborted
instead. A new goal preempts the running one, as move_base does.

``--battery PERCENT`` publishes sensor_msgs/BatteryState on /battery (5 Hz and at every change), or with
``--kobuki DIR`` the Kobuki's kobuki_msgs/SensorState on /mobile_base/sensors/core (the voltage on the Kobuki's
percentage line, in 0.1 V; the charger DOCKING_CHARGED once docked); ``--low-at-goal N`` drops it to 20 % when
the N-th goal arrives. ``--dock DIR`` also serves the Kobuki's
/dock_drive_action (kobuki_msgs/AutoDocking, whose message classes are generated with genpy from the definitions
in DIR/<Type>.msgdef, since Debian has no kobuki_msgs): a dock goal succeeds after ``--delay`` and the battery is
then full; with ``--dock-hung`` the docking driver takes goals but never names one in a status (hung).

Each goal, cancel and result is printed (``goal ID X Y``, ``cancel ID``, ``result ID STATUS``, and ``dock ID``,
``dock-result ID STATUS``) for the test to read; ``ready`` once everything is advertised and subscribed.
"""

import argparse
import math
import threading
from pathlib import Path

import genpy.dynamic
import rospy
from actionlib_msgs.msg import GoalID, GoalStatus, GoalStatusArray
from geometry_msgs.msg import PoseWithCovarianceStamped
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult
from sensor_msgs.msg import BatteryState

KEEP_FINISHED = 5.0
LOW_PERCENT = 20.0


class StandInServer:
    """One action server on plain topics: goals finish ``delay`` s after they arrive, as ``decide`` says."""

    def __init__(self, ns, goal_cls, result_cls, delay, decide, prefix, lock, hung=False):
        self.ns, self.result_cls, self.delay, self.decide, self.prefix, self.lock = (
            ns, result_cls, delay, decide, prefix, lock)
        self.hung = hung  # goals are printed but never named in a status nor finished
        self.goals = {}  # id -> dict(status, due, goal_id, msg, finished_at)
        self.status_pub = rospy.Publisher(ns + "/status", GoalStatusArray, queue_size=10)
        self.result_pub = rospy.Publisher(ns + "/result", result_cls, queue_size=10)
        self.on_goal_hooks = []
        self.received = 0
        rospy.Subscriber(ns + "/goal", goal_cls, self.on_goal, queue_size=10)
        rospy.Subscriber(ns + "/cancel", GoalID, self.on_cancel, queue_size=10)

    def on_goal(self, msg):
        gid = msg.goal_id.id
        if self.hung:
            print(self.prefix + " " + gid + self.describe(msg), flush=True)
            return
        with self.lock:
            for other in self.goals.values():
                if other["status"] == GoalStatus.ACTIVE:
                    self.finish(other, GoalStatus.PREEMPTED, "preempted by a new goal")
            self.goals[gid] = {"status": GoalStatus.ACTIVE, "due": rospy.get_time() + self.delay,
                               "goal_id": msg.goal_id, "msg": msg, "finished_at": None}
            self.received += 1
            for hook in self.on_goal_hooks:
                hook(self.received, msg)
        print(self.prefix + " " + gid + self.describe(msg), flush=True)

    def describe(self, msg):
        if hasattr(msg.goal, "target_pose"):
            position = msg.goal.target_pose.pose.position
            return f" {position.x!r} {position.y!r}"
        return ""

    def on_cancel(self, msg):
        print(f"cancel {msg.id}", flush=True)
        with self.lock:
            goal = self.goals.get(msg.id)
            if goal is not None and goal["status"] == GoalStatus.ACTIVE:
                self.finish(goal, GoalStatus.PREEMPTED, "cancelled")

    def finish(self, goal, status, text):
        goal["status"] = status
        goal["finished_at"] = rospy.get_time()
        result = self.result_cls()
        result.header.stamp = rospy.Time.now()
        result.status.goal_id = goal["goal_id"]
        result.status.status = status
        result.status.text = text
        self.result_pub.publish(result)
        print(f"{'result' if self.prefix == 'goal' else self.prefix + '-result'} {goal['goal_id'].id} {status}",
              flush=True)

    def tick(self, now):
        with self.lock:
            for goal in list(self.goals.values()):
                if goal["status"] == GoalStatus.ACTIVE and now >= goal["due"]:
                    status, text = self.decide(goal["msg"])
                    self.finish(goal, status, text)
            for gid, goal in list(self.goals.items()):
                if goal["finished_at"] is not None and now - goal["finished_at"] > KEEP_FINISHED:
                    del self.goals[gid]
            array = GoalStatusArray()
            array.header.stamp = rospy.Time.now()
            for goal in self.goals.values():
                array.status_list.append(GoalStatus(goal_id=goal["goal_id"], status=goal["status"]))
        self.status_pub.publish(array)


class StandInRobot:
    def __init__(self, args):
        self.lock = threading.RLock()
        self.aborts = [tuple(float(v) for v in text.split(",")) for text in args.abort]
        x, y, yaw = (float(v) for v in args.start.split(","))
        self.pose = (x, y, math.sin(yaw / 2.0), math.cos(yaw / 2.0))
        self.battery = args.battery
        self.charged = False
        self.low_at_goal = args.low_at_goal
        self.pose_pub = rospy.Publisher("/amcl_pose", PoseWithCovarianceStamped, queue_size=10)
        self.battery_pub = self.kobuki_pub = None
        if args.kobuki:
            self.sensor_state = genpy.dynamic.generate_dynamic(
                "kobuki_msgs/SensorState", (Path(args.kobuki) / "SensorState.msgdef").read_text()
            )["kobuki_msgs/SensorState"]
            self.kobuki_pub = rospy.Publisher("/mobile_base/sensors/core", self.sensor_state, queue_size=10)
        elif args.battery is not None:
            self.battery_pub = rospy.Publisher("/battery", BatteryState, queue_size=10)
        self.servers = [StandInServer("/move_base", MoveBaseActionGoal, MoveBaseActionResult, args.delay,
                                      self.drive, "goal", self.lock)]
        self.servers[0].on_goal_hooks.append(self.maybe_drain)
        if args.dock:
            classes = {}
            for name in ("AutoDockingActionGoal", "AutoDockingActionResult"):
                text = (Path(args.dock) / (name + ".msgdef")).read_text()
                classes.update(genpy.dynamic.generate_dynamic("kobuki_msgs/" + name, text))
            self.servers.append(StandInServer(
                "/dock_drive_action", classes["kobuki_msgs/AutoDockingActionGoal"],
                classes["kobuki_msgs/AutoDockingActionResult"], args.delay, self.dock, "dock", self.lock,
                hung=args.dock_hung))
            md5 = {name: classes["kobuki_msgs/" + name]._md5sum
                   for name in ("AutoDockingActionGoal", "AutoDockingActionResult")}
            print(f"genpy-md5 {md5['AutoDockingActionGoal']} {md5['AutoDockingActionResult']}", flush=True)

    def drive(self, msg):
        target = msg.goal.target_pose.pose
        if any(math.hypot(target.position.x - x, target.position.y - y) < 0.05 for x, y in self.aborts):
            return GoalStatus.ABORTED, "no path to the goal"
        self.pose = (target.position.x, target.position.y, target.orientation.z, target.orientation.w)
        return GoalStatus.SUCCEEDED, "goal reached"

    def dock(self, _msg):
        self.battery, self.charged = 100.0, True
        self.publish_battery()
        return GoalStatus.SUCCEEDED, "Arrived on docking station successfully."

    def maybe_drain(self, count, _msg):
        if self.battery is not None and count == self.low_at_goal:
            self.battery, self.charged = LOW_PERCENT, False
            self.publish_battery()

    def publish_battery(self):
        if self.kobuki_pub is not None and self.battery is not None:
            volts = 13.2 + (self.battery - 5.0) * (16.5 - 13.2) / 95.0
            self.kobuki_pub.publish(self.sensor_state(battery=round(volts * 10), charger=2 if self.charged else 0))
        if self.battery_pub is not None:
            status = (BatteryState.POWER_SUPPLY_STATUS_FULL if self.charged
                      else BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
            self.battery_pub.publish(BatteryState(percentage=self.battery / 100.0, voltage=15.0,
                                                  power_supply_status=status))

    def tick(self, _event):
        now = rospy.get_time()
        for server in self.servers:
            server.tick(now)

    def publish_pose(self, _event):
        msg = PoseWithCovarianceStamped()
        msg.header.stamp = rospy.Time.now()
        msg.header.frame_id = "map"
        msg.pose.pose.position.x, msg.pose.pose.position.y = self.pose[0], self.pose[1]
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = self.pose[2], self.pose[3]
        self.pose_pub.publish(msg)
        with self.lock:
            self.publish_battery()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--delay", type=float, default=0.3)
    parser.add_argument("--abort", action="append", default=[], metavar="X,Y")
    parser.add_argument("--start", default="0,0,0", metavar="X,Y,YAW")
    parser.add_argument("--battery", type=float, default=None, metavar="PERCENT")
    parser.add_argument("--low-at-goal", type=int, default=0, metavar="N")
    parser.add_argument("--dock", default=None, metavar="DIR")
    parser.add_argument("--kobuki", default=None, metavar="DIR")
    parser.add_argument("--dock-hung", action="store_true")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("move_base_stand_in")
    robot = StandInRobot(args)
    rospy.Timer(rospy.Duration(0.1), robot.tick)
    rospy.Timer(rospy.Duration(0.2), robot.publish_pose)
    print("ready", flush=True)
    rospy.spin()


if __name__ == "__main__":
    main()
