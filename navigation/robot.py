"""The simulated TurtleBot 2: a differential-drive disc with speed and acceleration limits, and its odometry.

Commands are velocities (like ``cmd_vel``); the base ramps towards them within its acceleration limits,
as the Kobuki's velocity smoother does. Odometry integrates the motion the wheels actually made, with
optional noise, and drifts from the true pose exactly as wheel odometry does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import Pose2D, wrap_angle


@dataclass(frozen=True)
class RobotParams:
    """TurtleBot 2 defaults: radius 0.18 m and the turtlebot_navigation speed/acceleration limits."""

    radius: float = 0.18
    max_linear: float = 0.5
    max_angular: float = 1.9
    linear_accel: float = 1.0
    angular_accel: float = 2.0


def _ramp(current: float, target: float, limit: float) -> float:
    if target > current + limit:
        return current + limit
    if target < current - limit:
        return current - limit
    return target


class DiffDriveRobot:
    """True pose and velocity of the base; :meth:`propose` gives the next pose, the world accepts it."""

    def __init__(self, pose: Pose2D, params: RobotParams | None = None) -> None:
        self.params = params or RobotParams()
        self.x, self.y, self.yaw = pose.x, pose.y, wrap_angle(pose.yaw)
        self.v = 0.0
        self.w = 0.0

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def set_pose(self, pose: Pose2D) -> None:
        self.x, self.y, self.yaw = pose.x, pose.y, wrap_angle(pose.yaw)

    def propose(self, cmd_v: float, cmd_w: float, dt: float) -> tuple[float, float, float, float, float]:
        """Velocities after the acceleration ramp and the pose they lead to: (x, y, yaw, v, w)."""
        p = self.params
        cmd_v = max(-p.max_linear, min(p.max_linear, cmd_v))
        cmd_w = max(-p.max_angular, min(p.max_angular, cmd_w))
        v = _ramp(self.v, cmd_v, p.linear_accel * dt)
        w = _ramp(self.w, cmd_w, p.angular_accel * dt)
        if abs(w) < 1e-9:
            x = self.x + v * dt * math.cos(self.yaw)
            y = self.y + v * dt * math.sin(self.yaw)
        else:  # exact arc for constant v, w over the step
            r = v / w
            yaw1 = self.yaw + w * dt
            x = self.x + r * (math.sin(yaw1) - math.sin(self.yaw))
            y = self.y - r * (math.cos(yaw1) - math.cos(self.yaw))
        return x, y, wrap_angle(self.yaw + w * dt), v, w

    def accept(self, x: float, y: float, yaw: float, v: float, w: float) -> None:
        self.x, self.y, self.yaw, self.v, self.w = x, y, yaw, v, w

    def stop(self) -> None:
        """Halt at once (a bumper hit, or the shutdown of the base)."""
        self.v = 0.0
        self.w = 0.0


class Odometry:
    """Wheel odometry in its own ``odom`` frame, starting at (0, 0, 0) like the Kobuki's.

    ``linear_noise`` and ``angular_noise`` are the standard deviations of the relative error of each
    step's travelled distance and turned angle (e.g. 0.02 = 2 %); zero gives perfect odometry.
    """

    def __init__(self, linear_noise: float = 0.0, angular_noise: float = 0.0,
                 rng: np.random.Generator | None = None) -> None:
        self.linear_noise = linear_noise
        self.angular_noise = angular_noise
        self.rng = rng or np.random.default_rng(0)
        self.x = self.y = self.yaw = 0.0
        self.distance = 0.0

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def update(self, ds: float, dyaw: float) -> None:
        """Integrate one step of true motion: ``ds`` metres along the heading and ``dyaw`` radians."""
        if self.linear_noise and ds:
            ds *= 1.0 + self.rng.normal(0.0, self.linear_noise)
        if self.angular_noise and dyaw:
            dyaw *= 1.0 + self.rng.normal(0.0, self.angular_noise)
        mid = self.yaw + 0.5 * dyaw
        self.x += ds * math.cos(mid)
        self.y += ds * math.sin(mid)
        self.yaw = wrap_angle(self.yaw + dyaw)
        self.distance += abs(ds)
