"""The local controller: follow a planned path and stop within the goal tolerances.

A pure-pursuit follower (steer for a point a short look-ahead distance down the path) that turns in
place when the path turns sharply, slows down so that its acceleration limit can stop it on the goal,
then turns to the goal heading. The tolerances default to the TurtleBot's move_base settings:
0.15 m and 0.3 rad. Given the time step, it never commands more than one step can take without passing
the goal or the heading it turns to, so coarse steps (``--dt 1.0``) settle on the goal instead of
circling it. It also reports how much of the path is still to go, which is what move_base's progress
check watches.
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


def _turn_rate(error: float, p: FollowerParams, dt: float | None = None) -> float:
    """Turn towards ``error`` as fast as still lets the acceleration limit stop the turn on target.

    With the time step ``dt``, no faster than turns the whole error in one step (no overshoot).
    """
    rate = min(p.heading_gain * abs(error), math.sqrt(1.6 * p.angular_accel * abs(error)), p.max_angular)
    if dt is not None:
        rate = min(rate, abs(error) / dt)
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
        self._t = 0.0  # fraction along ``segment`` of the robot's last projection on the path
        self.xy_reached = False
        seg = np.diff(self.path, axis=0)
        self._seg_len = np.hypot(seg[:, 0], seg[:, 1]) if len(seg) else np.zeros(0)
        # Path length still ahead from the start of each segment, for the stopping-distance speed limit.
        self._remaining = np.concatenate([np.cumsum(self._seg_len[::-1])[::-1], [0.0]])
        # Path still to drive (plus the distance back to the path): the measure of progress.
        self.to_go = float(self._remaining[0])

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

    def ahead(self) -> np.ndarray:
        """The path still to drive, from the robot's last projection on it to the goal."""
        k, t = self.segment, self._t
        if k >= len(self._seg_len):
            return self.path[-1:].copy()
        a, b = self.path[k], self.path[k + 1]
        return np.vstack([a + t * (b - a), self.path[k + 1:]])

    def command(self, pose: Pose2D, dt: float | None = None) -> tuple[float, float, bool]:
        """(v, w, goal reached) for ``pose``; ``dt`` (the control period) keeps one step from overshooting."""
        p = self.params
        d_goal = math.hypot(self.goal.x - pose.x, self.goal.y - pose.y)
        if self.xy_reached and d_goal > 2.0 * p.xy_tolerance:
            self.xy_reached = False  # pushed away from the goal: drive back
        if not self.xy_reached and d_goal < 0.4 * p.xy_tolerance:
            self.xy_reached = True
        if self.xy_reached:
            self.to_go = d_goal
            err = wrap_angle(self.goal.yaw - pose.yaw)
            if abs(err) <= 0.6 * p.yaw_tolerance and d_goal <= p.xy_tolerance:
                return 0.0, 0.0, True
            return 0.0, _turn_rate(err, p, dt), False

        k, t = self._project(pose.x, pose.y)
        self.segment, self._t = k, t
        cx, cy, remaining = self._carrot(k, t)
        if len(self._seg_len):
            a, b = self.path[k], self.path[k + 1]
            off = math.hypot(a[0] + t * (b[0] - a[0]) - pose.x, a[1] + t * (b[1] - a[1]) - pose.y)
        else:
            off = d_goal
        self.to_go = remaining + off
        if d_goal < p.lookahead:
            cx, cy = self.goal.x, self.goal.y
        alpha = wrap_angle(math.atan2(cy - pose.y, cx - pose.x) - pose.yaw)
        if abs(alpha) > p.rotate_threshold:
            return 0.0, _turn_rate(alpha, p, dt), False
        stop_dist = max(0.0, max(remaining, d_goal) - 0.2 * p.xy_tolerance)
        v = min(p.max_linear, math.sqrt(1.6 * p.linear_accel * stop_dist))
        if dt is not None:
            v = min(v, d_goal / dt)  # one step never carries the robot past the goal
        v *= max(0.0, math.cos(alpha)) ** 2
        lookahead = max(math.hypot(cx - pose.x, cy - pose.y), 1e-3)
        w = v * 2.0 * math.sin(alpha) / lookahead
        if abs(w) > p.max_angular:
            v *= p.max_angular / abs(w)  # keep the arc, slow down
            w = math.copysign(p.max_angular, w)
        return v, w, False
