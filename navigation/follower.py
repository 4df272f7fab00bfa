"""The local controller: follow a planned path and stop within the goal tolerances.

A pure-pursuit follower (steer for a point a short look-ahead distance down the path) that turns in
place when the path turns sharply, slows down so that its acceleration limit can stop it on the goal,
then turns to the goal heading. The tolerances default to the TurtleBot's move_base settings:
0.15 m and 0.3 rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import Pose2D, wrap_angle


@dataclass(frozen=True)
class FollowerParams:
    xy_tolerance: float = 0.15
    yaw_tolerance: float = 0.3
    lookahead: float = 0.35
    max_linear: float = 0.5
    max_angular: float = 1.9
    linear_accel: float = 1.0
    angular_accel: float = 2.0
    heading_gain: float = 2.5
    rotate_threshold: float = 0.8


def _turn_rate(error: float, p: FollowerParams) -> float:
    """Turn towards ``error`` as fast as still lets the acceleration limit stop the turn on target."""
    rate = min(p.heading_gain * abs(error), math.sqrt(1.6 * p.angular_accel * abs(error)), p.max_angular)
    return math.copysign(rate, error)


class PathFollower:
    """Tracks one path to one goal; :meth:`command` returns (v, w) and whether the goal is reached."""

    def __init__(self, path: np.ndarray, goal: Pose2D, params: FollowerParams | None = None) -> None:
        self.params = params or FollowerParams()
        self.path = np.asarray(path, dtype=np.float64)
        if len(self.path) == 0:
            self.path = np.array([[goal.x, goal.y]])
        self.goal = goal
        self.segment = 0
        self.xy_reached = False
        seg = np.diff(self.path, axis=0)
        self._seg_len = np.hypot(seg[:, 0], seg[:, 1]) if len(seg) else np.zeros(0)
        # Path length still ahead from the start of each segment, for the stopping-distance speed limit.
        self._remaining = np.concatenate([np.cumsum(self._seg_len[::-1])[::-1], [0.0]])

    def _project(self, x: float, y: float) -> tuple[int, float]:
        """Closest point on the path near the current segment: (segment, fraction along it)."""
        best = (self.segment, 0.0)
        best_d = math.inf
        for k in range(self.segment, min(self.segment + 8, len(self._seg_len))):
            ax, ay = self.path[k]
            length = self._seg_len[k]
            if length < 1e-9:
                t = 0.0
            else:
                bx, by = self.path[k + 1]
                t = max(0.0, min(1.0, ((x - ax) * (bx - ax) + (y - ay) * (by - ay)) / (length * length)))
            px = ax + t * (self.path[k + 1][0] - ax)
            py = ay + t * (self.path[k + 1][1] - ay)
            d = math.hypot(x - px, y - py)
            if d < best_d - 1e-9:
                best, best_d = (k, t), d
        return best

    def _carrot(self, k: int, t: float) -> tuple[float, float, float]:
        """The look-ahead point and the path length left from the projection (k, t)."""
        left = self.params.lookahead
        remaining = self._remaining[k] - t * self._seg_len[k] if len(self._seg_len) else 0.0
        while k < len(self._seg_len):
            length = self._seg_len[k]
            avail = (1.0 - t) * length
            if avail >= left:
                a, b = self.path[k], self.path[k + 1]
                s = t + left / length
                return a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), remaining
            left -= avail
            k += 1
            t = 0.0
        return self.goal.x, self.goal.y, remaining

    def command(self, pose: Pose2D) -> tuple[float, float, bool]:
        p = self.params
        d_goal = math.hypot(self.goal.x - pose.x, self.goal.y - pose.y)
        if self.xy_reached and d_goal > 2.0 * p.xy_tolerance:
            self.xy_reached = False  # pushed away from the goal: drive back
        if not self.xy_reached and d_goal < 0.4 * p.xy_tolerance:
            self.xy_reached = True
        if self.xy_reached:
            err = wrap_angle(self.goal.yaw - pose.yaw)
            if abs(err) <= 0.6 * p.yaw_tolerance and d_goal <= p.xy_tolerance:
                return 0.0, 0.0, True
            return 0.0, _turn_rate(err, p), False

        k, t = self._project(pose.x, pose.y)
        self.segment = k
        cx, cy, remaining = self._carrot(k, t)
        if d_goal < p.lookahead:
            cx, cy = self.goal.x, self.goal.y
        alpha = wrap_angle(math.atan2(cy - pose.y, cx - pose.x) - pose.yaw)
        if abs(alpha) > p.rotate_threshold:
            return 0.0, _turn_rate(alpha, p), False
        stop_dist = max(0.0, max(remaining, d_goal) - 0.2 * p.xy_tolerance)
        v = min(p.max_linear, math.sqrt(1.6 * p.linear_accel * stop_dist))
        v *= max(0.0, math.cos(alpha)) ** 2
        lookahead = max(math.hypot(cx - pose.x, cy - pose.y), 1e-3)
        w = v * 2.0 * math.sin(alpha) / lookahead
        if abs(w) > p.max_angular:
            v *= p.max_angular / abs(w)  # keep the arc, slow down
            w = math.copysign(p.max_angular, w)
        return v, w, False
