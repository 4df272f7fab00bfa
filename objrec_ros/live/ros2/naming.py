"""ROS 2 topic and type names, and their spelling on DDS, as a default ROS 2 installation uses them.

ROS 2's design article "Topic and Service name mapping to DDS" sets the rules for names; the RMW layers
(``rmw_cyclonedds_cpp``, ``rmw_fastrtps_cpp``) put a fully qualified topic ``/camera/image_raw`` on the DDS
topic ``rt/camera/image_raw`` and a message type ``sensor_msgs/msg/Image`` on the DDS type
``sensor_msgs::msg::dds_::Image_``. A name that breaks the rules is refused here with one line, before
anything reaches the network, because a ROS 2 peer would never match it and the user would only see
silence.
"""

from __future__ import annotations

import re

from ..transport import LiveError

#: The prefix of every plain ROS 2 topic on DDS (services use rq/, rr/; actions their topics' rt/).
TOPIC_PREFIX = "rt/"
#: The longest fully qualified topic name: DDS's 255 characters less 8 reserved for prefixes (rmw's
#: RMW_TOPIC_MAX_NAME_LENGTH).
MAX_TOPIC_LENGTH = 255 - 8

_ALLOWED = re.compile(r"[A-Za-z0-9_/~{}]*")
_PACKAGE = re.compile(r"[a-z][a-z0-9_]*")
_INTERFACE_KINDS = ("msg", "srv", "action")
_TYPE_NAME = re.compile(r"[A-Z][A-Za-z0-9_]*")
_DDS_TYPE = re.compile(r"(\w+)::(\w+)::dds_::(\w+)_")


def _bad_topic(topic: str, why: str) -> LiveError:
    return LiveError(f"ros2: topic {topic!r} is not a valid ROS 2 name: {why}")


def fully_qualified(topic: str, node_name: str = "objrec") -> str:
    """``topic`` as a fully qualified ROS 2 name (``/a/b``), checked against ROS 2's naming rules.

    A relative name is taken in the root namespace (objrec's node has no namespace), ``~`` stands for the
    node (``~/x`` is ``/objrec/x``); substitutions (``{sub}``) are refused: no ROS 2 node is here to define
    them. LiveError (one line, naming the topic and the broken rule) otherwise.
    """
    if not topic:
        raise _bad_topic(topic, "it is empty")
    if not _ALLOWED.fullmatch(topic):
        bad = next(c for c in topic if not _ALLOWED.fullmatch(c))
        raise _bad_topic(topic, f"{bad!r} is not allowed (only letters, digits, '_' and '/')")
    if "{" in topic or "}" in topic:
        raise _bad_topic(topic, "substitutions ({...}) are not expanded here; give the name in full")
    if topic[0].isdigit():
        raise _bad_topic(topic, "it starts with a digit")
    if topic.endswith("/"):
        raise _bad_topic(topic, "it ends with '/'")
    if "//" in topic:
        raise _bad_topic(topic, "it has a repeated '/'")
    if "~" in topic[1:] or (topic.startswith("~") and topic not in ("~",) and not topic.startswith("~/")):
        raise _bad_topic(topic, "'~' may only begin the name, followed by '/' (~/name)")
    if topic.startswith("~"):
        name = "/" + node_name + topic[1:]
    elif topic.startswith("/"):
        name = topic
    else:
        name = "/" + topic
    for token in name[1:].split("/"):
        if token[0].isdigit():
            raise _bad_topic(topic, f"the token {token!r} starts with a digit")
    if len(name) > MAX_TOPIC_LENGTH:
        raise _bad_topic(topic, f"it is {len(name)} characters long, at most {MAX_TOPIC_LENGTH} are allowed")
    return name


def dds_topic(topic: str, node_name: str = "objrec") -> str:
    """The DDS topic of a ROS 2 topic: ``/camera/image_raw`` -> ``rt/camera/image_raw``."""
    return TOPIC_PREFIX + fully_qualified(topic, node_name)[1:]


def ros_topic(dds_name: str) -> str | None:
    """The ROS 2 topic of a DDS topic, or None when it is not a plain ROS 2 topic (no ``rt/`` prefix)."""
    if not dds_name.startswith(TOPIC_PREFIX) or len(dds_name) == len(TOPIC_PREFIX):
        return None
    return "/" + dds_name[len(TOPIC_PREFIX):]


def dds_type(msgtype: str) -> str:
    """The DDS type name of a ROS 2 message type: ``sensor_msgs/msg/Image`` -> ``sensor_msgs::msg::dds_::Image_``.

    ``msgtype`` is in rosbags' form (package/msg/Name); LiveError naming it when it is not a ROS 2 type name.
    """
    parts = msgtype.split("/")
    if len(parts) != 3:
        raise LiveError(f"ros2: type {msgtype!r} is not a ROS 2 type name (package/msg/Name)")
    package, kind, name = parts
    if not _PACKAGE.fullmatch(package) or "__" in package or package.endswith("_"):
        raise LiveError(f"ros2: type {msgtype!r}: the package {package!r} is not a ROS 2 package name "
                        "(lower case letters, digits and single '_', starting with a letter)")
    if kind not in _INTERFACE_KINDS:
        raise LiveError(f"ros2: type {msgtype!r}: {kind!r} is not one of {', '.join(_INTERFACE_KINDS)}")
    if not _TYPE_NAME.fullmatch(name) or (kind == "msg" and "_" in name):
        raise LiveError(f"ros2: type {msgtype!r}: {name!r} is not a ROS 2 message name "
                        "(letters and digits, starting with a capital)")
    return f"{package}::{kind}::dds_::{name}_"


def ros_type(dds_name: str) -> str | None:
    """The ROS 2 type (rosbags' form) of a DDS type name, or None when it is not a ROS 2 type."""
    match = _DDS_TYPE.fullmatch(dds_name)
    if match is None:
        return None
    return "/".join(match.groups())
