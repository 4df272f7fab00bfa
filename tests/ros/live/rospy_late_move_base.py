#!/usr/bin/env python3
"""A move_base that answers late, or never, or falls silent, written with rospy for the live deadline tests (run
by Debian's /usr/bin/python3).

It holds the topics a patrol waits for (it subscribes to /move_base/goal and /move_base/cancel and publishes
/move_base/status at 10 Hz, so the patrol sees a move_base that takes goals), but:

* ``--late-goals N --late-by S``: each of the first N goals is taken only S seconds after it arrived (``never``:
  not at all); until then no status names it. Later goals are taken at once.
* ``--mute-after N``: half a second after the N-th goal is taken (a few statuses have named it), nothing more is
  published on /move_base/status or /move_base/result (a move_base that hangs mid-goal).

A taken goal is named ACTIVE in the status and succeeds ``--delay`` s later. A cancel for a goal not taken yet is
kept, and the goal is RECALLED when it is taken, as actionlib's server does. No pose and no battery are
published. It prints ``goal ID``, ``taken ID``, ``cancel ID``, ``recalled ID``, ``result ID STATUS``, and
``ready`` once everything is advertised and subscribed.
"""

import argparse
import math
import threading

import rospy
from actionlib_msgs.msg import GoalID, GoalStatus, GoalStatusArray
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult


class LateMoveBase:
    def __init__(self, args):
        self.args = args
        self.lock = threading.Lock()
        self.held = []  # (take_at, msg) of goals not taken yet
        self.cancelled = set()  # ids cancelled before they were taken
        self.goals = {}  # id -> dict(goal_id, status, due)
        self.arrived = 0
        self.taken = 0
        self.muted = False
        self.mute_at = math.inf
        self.status_pub = rospy.Publisher("/move_base/status", GoalStatusArray, queue_size=10)
        self.result_pub = rospy.Publisher("/move_base/result", MoveBaseActionResult, queue_size=10)
        rospy.Subscriber("/move_base/goal", MoveBaseActionGoal, self.on_goal, queue_size=10)
        rospy.Subscriber("/move_base/cancel", GoalID, self.on_cancel, queue_size=10)

    def on_goal(self, msg):
        print(f"goal {msg.goal_id.id}", flush=True)
        with self.lock:
            self.arrived += 1
            late = self.arrived <= self.args.late_goals
            self.held.append((rospy.get_time() + (self.args.late_by if late else 0.0), msg))

    def on_cancel(self, msg):
        print(f"cancel {msg.id}", flush=True)
        with self.lock:
            goal = self.goals.get(msg.id)
            if goal is None:
                self.cancelled.add(msg.id)
            elif goal["status"] == GoalStatus.ACTIVE:
                self.finish(goal, GoalStatus.PREEMPTED, "cancelled")

    def take(self, msg, now):
        gid = msg.goal_id.id
        self.taken += 1
        print(f"taken {gid}", flush=True)
        goal = {"goal_id": msg.goal_id, "status": GoalStatus.ACTIVE, "due": now + self.args.delay}
        self.goals[gid] = goal
        if gid in self.cancelled:
            print(f"recalled {gid}", flush=True)
            self.finish(goal, GoalStatus.RECALLED, "cancelled before it was taken")
        if self.args.mute_after and self.taken == self.args.mute_after:
            self.mute_at = now + 0.5

    def finish(self, goal, status, text):
        goal["status"] = status
        if self.muted:
            return
        result = MoveBaseActionResult()
        result.header.stamp = rospy.Time.now()
        result.status.goal_id = goal["goal_id"]
        result.status.status = status
        result.status.text = text
        self.result_pub.publish(result)
        print(f"result {goal['goal_id'].id} {status}", flush=True)

    def tick(self, _event):
        now = rospy.get_time()
        with self.lock:
            for item in [h for h in self.held if h[0] <= now]:
                self.held.remove(item)
                self.take(item[1], now)
            for goal in self.goals.values():
                if goal["status"] == GoalStatus.ACTIVE and now >= goal["due"]:
                    self.finish(goal, GoalStatus.SUCCEEDED, "goal reached")
            if now >= self.mute_at and not self.muted:
                self.muted = True
                print("muted", flush=True)
            if self.muted:
                return
            array = GoalStatusArray()
            array.header.stamp = rospy.Time.now()
            for goal in self.goals.values():
                array.status_list.append(GoalStatus(goal_id=goal["goal_id"], status=goal["status"]))
        self.status_pub.publish(array)


def seconds(text):
    return math.inf if text == "never" else float(text)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--delay", type=float, default=0.3)
    parser.add_argument("--late-goals", type=int, default=0, metavar="N")
    parser.add_argument("--late-by", type=seconds, default=0.0, metavar="SECONDS|never")
    parser.add_argument("--mute-after", type=int, default=0, metavar="N")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("late_move_base")
    server = LateMoveBase(args)
    rospy.Timer(rospy.Duration(0.1), server.tick)
    print("ready", flush=True)
    rospy.spin()


if __name__ == "__main__":
    main()
