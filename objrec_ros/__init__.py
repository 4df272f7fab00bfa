"""objrec_ros: ROS data in and out without a ROS installation (rosbags, pure Python).

- :mod:`objrec_ros.bags`: open ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) and bare MCAP files
  (:func:`open_recording`), list their topics (:func:`list_topics`), read their messages decoded.
- :mod:`objrec_ros.decode`: ``sensor_msgs`` images, point clouds and depth + CameraInfo pairs as NumPy arrays.
- :mod:`objrec_ros.source`: what the kinds' bag sources (``objrec2d.bag_source``, ``objrec3d.bag_source``)
  share.

It imports rosbags, NumPy, objrec_core and strictio only: no OpenCV, Open3D, Qt or kind package, so each kind
brings what it needs (OpenCV decodes compressed images in objrec2d).
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
