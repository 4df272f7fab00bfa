"""ROS 1 without rospy: the master's XML-RPC API, a node's Slave API and TCPROS, over the standard library.

Message bytes are ROS 1 serialization as rosbags writes it; md5sums and definitions come from rosbags'
typestores. See :mod:`objrec_ros.live.transport` for the interface and :mod:`.node` for the node.
"""

from __future__ import annotations

from .node import Ros1Transport

__all__ = ["Ros1Transport"]
