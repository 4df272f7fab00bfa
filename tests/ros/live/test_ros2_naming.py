"""ROS 2 topic and type names and their DDS spelling, checked against ROS 2's own rules and examples.

The examples are those of ROS 2's design article "Topic and Service name mapping to DDS" and of rmw's
``rmw_validate_full_topic_name`` (at most 247 characters); the DDS spelling is what rmw_cyclonedds and
rmw_fastrtps put on the wire (``rt/`` + the name without its leading slash, ``pkg::msg::dds_::Type_``).
No DDS is needed: the naming module imports no cyclonedds.
"""

from __future__ import annotations

import pytest

from objrec_ros.live import LiveError
from objrec_ros.live.ros2.naming import (
    MAX_TOPIC_LENGTH,
    dds_topic,
    dds_type,
    fully_qualified,
    ros_topic,
    ros_type,
)


@pytest.mark.parametrize(("name", "expanded"), [
    ("foo", "/foo"), ("abc123", "/abc123"), ("_foo", "/_foo"), ("Foo", "/Foo"), ("BAR", "/BAR"),
    ("~", "/objrec"), ("foo/bar", "/foo/bar"), ("~/foo", "/objrec/foo"), ("foo/_bar", "/foo/_bar"),
    ("/foo", "/foo"), ("/bar/baz", "/bar/baz"), ("/_private/thing", "/_private/thing"),
    ("/camera/color/image_raw", "/camera/color/image_raw"),
])
def test_valid_names_expand_as_the_design_article_says(name: str, expanded: str) -> None:
    assert fully_qualified(name) == expanded


@pytest.mark.parametrize(("name", "why"), [
    ("123abc", "starts with a digit"), ("123", "starts with a digit"), ("foo bar", "' ' is not allowed"),
    (" ", "' ' is not allowed"), ("foo//bar", "repeated '/'"), ("foo/", "ends with '/'"),
    ("~foo", "'~' may only begin"), ("foo~", "'~' may only begin"), ("foo~/bar", "'~' may only begin"),
    ("foo/~bar", "'~' may only begin"), ("/~", "'~' may only begin"), ("foo/~/bar", "'~' may only begin"),
    ("", "it is empty"), ("/foo/1bar", "the token '1bar' starts with a digit"),
    ("{node}/foo", "substitutions"), ("/caméra", "'é' is not allowed"), ("/a-b", "'-' is not allowed"),
])
def test_invalid_names_are_one_line_naming_the_topic_and_the_rule(name: str, why: str) -> None:
    with pytest.raises(LiveError) as caught:
        fully_qualified(name)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"ros2: topic {name!r} is not a valid ROS 2 name: ")
    assert why in message


def test_the_length_limit_is_rmws_247_characters() -> None:
    longest = "/" + "a" * (MAX_TOPIC_LENGTH - 1)
    assert MAX_TOPIC_LENGTH == 247
    assert fully_qualified(longest) == longest
    with pytest.raises(LiveError, match="248 characters long, at most 247"):
        fully_qualified(longest + "b")


def test_topics_on_dds_carry_the_rt_prefix_and_map_back() -> None:
    assert dds_topic("/camera/image_raw") == "rt/camera/image_raw"
    assert dds_topic("detected_objects_2d") == "rt/detected_objects_2d"
    assert dds_topic("~/annotated", node_name="objrec_detect") == "rt/objrec_detect/annotated"
    assert ros_topic("rt/camera/image_raw") == "/camera/image_raw"
    # DDS's and ROS 2's own topics are not ROS 2 topics.
    assert ros_topic("ros_discovery_info") is None
    assert ros_topic("rq/add_two_intsRequest") is None
    assert ros_topic("rt/") is None


@pytest.mark.parametrize(("msgtype", "dds"), [
    ("sensor_msgs/msg/Image", "sensor_msgs::msg::dds_::Image_"),
    ("sensor_msgs/msg/PointCloud2", "sensor_msgs::msg::dds_::PointCloud2_"),
    ("std_msgs/msg/String", "std_msgs::msg::dds_::String_"),
    ("object_detection_2d_msgs/msg/DetectedObject2DArray",
     "object_detection_2d_msgs::msg::dds_::DetectedObject2DArray_"),
    ("example_interfaces/action/Fibonacci_FeedbackMessage",
     "example_interfaces::action::dds_::Fibonacci_FeedbackMessage_"),
])
def test_types_on_dds_are_spelled_as_ros2s_generated_idl(msgtype: str, dds: str) -> None:
    assert dds_type(msgtype) == dds
    assert ros_type(dds) == msgtype


@pytest.mark.parametrize(("msgtype", "why"), [
    ("sensor_msgs/Image", "package/msg/Name"), ("Image", "package/msg/Name"),
    ("Sensor_msgs/msg/Image", "not a ROS 2 package name"), ("sensor__msgs/msg/Image", "not a ROS 2 package name"),
    ("sensor_msgs/msgs/Image", "not one of msg, srv, action"), ("sensor_msgs/msg/image", "not a ROS 2 message name"),
    ("sensor_msgs/msg/Im_age", "not a ROS 2 message name"),
])
def test_bad_type_names_are_refused_in_one_line(msgtype: str, why: str) -> None:
    with pytest.raises(LiveError, match=f"ros2: type '{msgtype}'") as caught:
        dds_type(msgtype)
    assert why in str(caught.value)
    assert "\n" not in str(caught.value)


def test_only_dds_types_spelled_as_ros2_spells_them_map_back() -> None:
    assert ros_type("rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_") == (
        "rmw_dds_common/msg/ParticipantEntitiesInfo")
    assert ros_type("org::eclipse::cyclonedds::builtin::DCPSParticipant") is None
    assert ros_type("test::Msg") is None
