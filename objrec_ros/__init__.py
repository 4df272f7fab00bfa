"""objrec_ros: ROS data in and out without a ROS installation (rosbags; cyclonedds for live ROS 2).

- :mod:`objrec_ros.bags`: open ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) and bare MCAP files
  (:func:`open_recording`), list their topics (:func:`list_topics`), read their messages decoded.
- :mod:`objrec_ros.decode`: ``sensor_msgs`` images, point clouds and depth + CameraInfo pairs as NumPy arrays.
- :mod:`objrec_ros.source`: what the kinds' bag sources (``objrec2d.bag_source``, ``objrec3d.bag_source``)
  share.
- :mod:`objrec_ros.encode`: detection arrays and pictures as typed message bytes, the one encoder of the bag
  writer (:mod:`objrec_ros.output`) and of live publishing.
- :mod:`objrec_ros.live`: live ROS 1 and ROS 2 topics in and out behind one transport interface (ROS 1's
  master and TCPROS, ROS 2 over DDS with cyclonedds), and what the kinds' live sources share.

It imports rosbags, NumPy, objrec_core, declare and strictio (and cyclonedds for ``ros2:``) only: no OpenCV,
Open3D, Qt or kind package, so each kind brings what it needs (OpenCV decodes compressed images in objrec2d).
"""

from .bags import (
    Recording,
    RecordingError,
    TopicInfo,
    is_recording_path,
    list_topics,
    open_recording,
)
from .decode import CloudArrays, DecodeError

__all__ = [
    "CloudArrays",
    "DecodeError",
    "Recording",
    "RecordingError",
    "TopicInfo",
    "is_recording_path",
    "list_topics",
    "open_recording",
]
