"""DistanceFilter: keep the points within a distance band from the sensor, the usual first 3D stage."""

from __future__ import annotations

from typing import Any

import numpy as np

from objrec_core import Choice, Float, Ordered

from .base import CloudFilter
from .cloud import PointCloud, as_cloud


class DistanceFilter(CloudFilter):
    """Drops points nearer than ``min_distance`` or farther than ``max_distance`` from the sensor.

    With ``measure = z`` the distance is the depth along the optical axis (PCL's pass-through on z, as in
    the cylinder tutorial); with ``euclidean`` it is the straight-line range from the sensor origin.
    """

    # No hard upper bound: how far a sensor sees is the sensor's business (a depth camera a few metres, a
    # lidar a hundred). The sliders cover a depth camera's range; both share it so they line up.
    min_distance = Float(0.0, "nearest distance kept, metres: closer points are sensor noise or the robot",
                         min=0.0, soft_max=10.0, step=0.05)
    max_distance = Float(1.5, "farthest distance kept, metres: the background only costs time",
                         min=0.0, soft_max=10.0, step=0.05)
    distance_order = Ordered("min_distance", "max_distance", why="every point would be dropped")
    measure = Choice("z", ["z", "euclidean"], "z: depth along the optical axis; euclidean: range from the sensor")

    def filter(self, frame: Any) -> PointCloud:
        cloud = as_cloud(frame)
        p = self.params
        if p.measure == "z":
            distance = cloud.points[:, 2] - np.float32(cloud.sensor_origin[2])
        else:
            distance = np.linalg.norm(cloud.points - cloud.sensor_origin.astype(np.float32), axis=1)
        keep = (distance >= p.min_distance) & (distance <= p.max_distance)  # NaN compares false
        return cloud.select(keep)
