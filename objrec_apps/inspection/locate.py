"""Where a detected object is in the map: from the camera frame it was found in and the robot's pose.

The kind contract gives each object's geometry without naming the kind (``Kind.outlines``): a 3D box is
placed at its centre, transformed from the optical frame by the camera's pose; a 2D polygon is placed by
the depth under it (the median over the polygon's pixels, robust to the background its outline takes in)
along the ray through its centroid: a point on the face the camera sees, which the verdict lifts to the
object's centre with the object's known size (:func:`.verdict.lift_to_centre`). The camera's pose is
computed from the pose the robot *believes* it has, as on the real robot, so localisation errors show in the
positions.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import cv2
import numpy as np

from navigation.camera import CameraPose
from navigation.geometry import Pose2D
from objrec_core import Kind

#: A polygon needs this many pixels with depth to be placed (fewer is noise or an edge).
MIN_DEPTH_PIXELS = 20


@dataclass(frozen=True)
class Sighting:
    """One detected object in one frame, placed in the map (metres)."""

    name: str
    x: float
    y: float
    z: float
    method: str  # "box" (3D) or "polygon" (2D, by its depth)
    frame: str
    taken_at: float
    range_m: float
    camera_x: float | None = None  # where the camera stood (map, metres): a polygon's depth is its near face
    camera_y: float | None = None

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        return {k: round(v, 3) if isinstance(v, float) else v for k, v in d.items()}


def believed_camera(frame: Any, believed: Pose2D) -> CameraPose:
    """The camera's pose if the robot were where it believes: the frame's mount offset, moved there."""
    robot, cam = frame.robot_pose, frame.camera_pose
    c, s = math.cos(robot.yaw), math.sin(robot.yaw)
    dx, dy = cam.x - robot.x, cam.y - robot.y
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    cb, sb = math.cos(believed.yaw), math.sin(believed.yaw)
    return CameraPose(believed.x + cb * lx - sb * ly, believed.y + sb * lx + cb * ly, cam.z,
                      believed.yaw + (cam.yaw - robot.yaw))


def polygon_point(polygon: np.ndarray, frame: Any) -> np.ndarray | None:
    """The optical-frame point under a polygon: its pixels' centroid at their median depth."""
    h, w = frame.depth.shape
    mask = np.zeros((h, w), np.uint8)
    cv2.fillPoly(mask, [np.round(np.asarray(polygon, np.float64)).astype(np.int32).reshape(-1, 1, 2)], 1)
    vs, us = np.nonzero(mask)
    depth = frame.depth[vs, us]
    good = np.isfinite(depth)
    if good.sum() < MIN_DEPTH_PIXELS:
        return None
    d = float(np.median(depth[good]))
    u, v = float(us.mean()), float(vs.mean())
    return np.array([(u - frame.cx) / frame.fx * d, (v - frame.cy) / frame.fy * d, d])


def locate(kind: Kind, array_type: Any, objects: list[Any], frame: Any, believed: Pose2D, label: str,
           t: float) -> list[Sighting]:
    """Map positions of the objects one system found in one frame (objects that cannot be placed are left out)."""
    cam = believed_camera(frame, believed)
    found = []
    for obj in objects:
        outlines = kind.outlines(array_type(objects=[obj]))
        if not outlines:
            continue
        outline = outlines[0]
        if outline.box is not None:
            optical, method = np.asarray(outline.box, np.float64).mean(axis=0), "box"
        elif outline.polygon is not None and len(outline.polygon) >= 3:
            optical, method = polygon_point(outline.polygon, frame), "polygon"
        else:
            continue
        if optical is None or not np.isfinite(optical).all():
            continue
        x, y, z = cam.camera_to_map(optical[None, :])[0]
        found.append(Sighting(str(getattr(obj, "name", outline.label)), float(x), float(y), float(z), method, label,
                              t, float(np.linalg.norm(optical)), cam.x, cam.y))
    return found
