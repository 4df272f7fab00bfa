"""Planar poses and the few angle/quaternion conversions the rest of the package needs.

Everything in the simulator is 2D (x, y, yaw); goal files carry ROS quaternions, so the
conversion lives here, once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def wrap_angle(angle: float) -> float:
    """Wrap an angle to (-pi, pi] so differences of headings never take the long way round."""
    a = math.fmod(angle + math.pi, 2.0 * math.pi)
    if a <= 0.0:
        a += 2.0 * math.pi
    return a - math.pi


def yaw_from_quaternion(qx: float, qy: float, qz: float, qw: float) -> float:
    """Heading (rotation about z) of a quaternion; roll and pitch are ignored as a planar robot must."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """The (qx, qy, qz, qw) of a pure rotation about z, as goal files write it."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


@dataclass(frozen=True)
class Pose2D:
    """A position in the map frame (metres) and a heading (radians, counter-clockwise from +x)."""

    x: float
    y: float
    yaw: float = 0.0

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)

    def heading_error_to(self, other: Pose2D) -> float:
        """Signed rotation that turns this heading into ``other``'s."""
        return wrap_angle(other.yaw - self.yaw)

    def ahead(self, distance: float) -> Pose2D:
        """The pose ``distance`` metres along this heading (negative: behind), same heading."""
        return Pose2D(self.x + distance * math.cos(self.yaw), self.y + distance * math.sin(self.yaw), self.yaw)

    def as_dict(self) -> dict[str, float]:
        return {"x": round(self.x, 4), "y": round(self.y, 4), "yaw": round(self.yaw, 4)}
