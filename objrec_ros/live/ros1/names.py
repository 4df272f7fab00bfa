"""ROS 1 names: message types in ROS 1's spelling and rosbags', node caller ids, topic names.

ROS 1 writes a type ``sensor_msgs/Image``; rosbags (and the transport interface) write it
``sensor_msgs/msg/Image``. Topic names are checked against ROS 1's graph-name rules before anything is sent,
so a typo is one clear line instead of a master that silently registers a topic nobody publishes.
"""

from __future__ import annotations

import itertools
import os
import re

from strictio.shown import printable

from ..transport import LiveError

# A graph resource name: segments of a letter then letters, digits and underscores, joined by '/'.
_SEGMENT = r"[A-Za-z][A-Za-z0-9_]*"
_GLOBAL_NAME = re.compile(rf"/(?:{_SEGMENT}/)*{_SEGMENT}")
_BASE_NAME = re.compile(_SEGMENT)
# ``pkg/Type`` (ROS 1) or ``pkg/msg/Type`` (rosbags).
_ROS1_TYPE = re.compile(rf"({_SEGMENT})/({_SEGMENT})")
_ROSBAGS_TYPE = re.compile(rf"({_SEGMENT})/msg/({_SEGMENT})")

_node_numbers = itertools.count(1)


def to_ros1_type(msgtype: str) -> str:
    """``sensor_msgs/msg/Image`` -> ``sensor_msgs/Image`` (a ROS 1 spelling is returned unchanged)."""
    if match := _ROSBAGS_TYPE.fullmatch(msgtype):
        return f"{match[1]}/{match[2]}"
    if _ROS1_TYPE.fullmatch(msgtype):
        return msgtype
    raise LiveError(f"message type '{printable(msgtype, 80)}' is not of the form package/msg/Type")


def from_ros1_type(ros1_type: str) -> str:
    """``sensor_msgs/Image`` -> ``sensor_msgs/msg/Image``; a name of another form (``*``, or something a
    foreign node made up) is returned unchanged, so listings show what is there."""
    if match := _ROS1_TYPE.fullmatch(ros1_type):
        return f"{match[1]}/msg/{match[2]}"
    return ros1_type


def topic_name(topic: str) -> str:
    """``topic`` as a global ROS 1 name (a relative ``camera/image`` is resolved in the root namespace, as a
    node started without a namespace does); LiveError naming it when it breaks the graph-name rules."""
    name = topic if topic.startswith("/") else "/" + topic
    if not _GLOBAL_NAME.fullmatch(name):
        raise LiveError(f"topic '{printable(topic, 80)}' is not a ROS 1 name: segments of a letter then letters,"
                        " digits or '_', separated by '/'")
    return name


def caller_id(node_name: str) -> str:
    """A node name unique to this process and call (``/objrec_4242_1``): two transports never share one,
    so the master never tells one of them to shut down because the other registered."""
    base = node_name.strip("/")
    if not _BASE_NAME.fullmatch(base):
        raise LiveError(f"node name '{printable(node_name, 80)}' is not a ROS 1 base name (a letter, then letters,"
                        " digits or '_')")
    return f"/{base}_{os.getpid()}_{next(_node_numbers)}"
