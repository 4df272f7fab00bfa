"""DDS types made from rosbags' definitions put exactly rosbags' CDR bytes on the wire.

For each message: rosbags serializes it (``serialize_cdr``, 4-byte header included), the run-time DDS type
reads those bytes back into a cyclonedds sample with the same field values, and writes them out as XCDR1
byte for byte the same. Two samples are also built field by field, never having seen rosbags' bytes, to
show the layout is not merely self-consistent.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from objrec2d.messages import DetectedObject2DArray
from objrec_ros.live import LiveError
from objrec_ros.live.ros2.dds_types import idl_struct
from objrec_ros.msgdefs import register_definitions, standard_typestore


@pytest.fixture
def store():
    typestore = standard_typestore(2)
    register_definitions(typestore, DetectedObject2DArray.ros_type, DetectedObject2DArray.ros_definitions)
    return typestore


def _header(store, frame_id: str = "camera_color_optical_frame"):
    t = store.types
    return t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=1_700_000_123, nanosec=456_789),
                                    frame_id=frame_id)


def _messages(store) -> dict[str, object]:
    t = store.types
    rng = np.random.default_rng(22)
    point = t["geometry_msgs/msg/Point32"]
    return {
        "sensor_msgs/msg/Image": t["sensor_msgs/msg/Image"](
            header=_header(store), height=3, width=5, encoding="bgr8", is_bigendian=0, step=15,
            data=rng.integers(0, 256, 45, dtype=np.uint8)),
        "sensor_msgs/msg/CompressedImage": t["sensor_msgs/msg/CompressedImage"](
            header=_header(store), format="jpeg", data=rng.integers(0, 256, 101, dtype=np.uint8)),
        "sensor_msgs/msg/PointCloud2": t["sensor_msgs/msg/PointCloud2"](
            header=_header(store, "depth"), height=1, width=3,
            fields=[t["sensor_msgs/msg/PointField"](name=n, offset=4 * i, datatype=7, count=1)
                    for i, n in enumerate("xyz")],
            is_bigendian=False, point_step=12, row_step=36,
            data=rng.random(9, dtype=np.float32).view(np.uint8), is_dense=True),
        "sensor_msgs/msg/CameraInfo": t["sensor_msgs/msg/CameraInfo"](
            header=_header(store), height=480, width=640, distortion_model="plumb_bob",
            d=np.array([0.1, -0.2, 0.001, 0.002, 0.0]),
            k=np.array([525.0, 0, 319.5, 0, 525.0, 239.5, 0, 0, 1]), r=np.eye(3).ravel(),
            p=np.array([525.0, 0, 319.5, 0, 0, 525.0, 239.5, 0, 0, 0, 1, 0]), binning_x=0, binning_y=0,
            roi=t["sensor_msgs/msg/RegionOfInterest"](x_offset=1, y_offset=2, height=3, width=4, do_rectify=True)),
        DetectedObject2DArray.ros_type: t[DetectedObject2DArray.ros_type](
            header=_header(store), objects=[
                t["object_detection_2d_msgs/msg/DetectedObject2D"](
                    name=name, truncated=False, polygon=t["geometry_msgs/msg/Polygon"](
                        points=[point(x=float(x), y=float(x) / 2, z=0.0) for x in range(k)]))
                for k, name in ((3, "cup"), (4, "bottle with a long label"), (0, ""))]),
        "diagnostic_msgs/msg/DiagnosticArray": t["diagnostic_msgs/msg/DiagnosticArray"](
            header=_header(store), status=[t["diagnostic_msgs/msg/DiagnosticStatus"](
                level=1, name="objrec: detector", message="slow frame", hardware_id="cam0",
                values=[t["diagnostic_msgs/msg/KeyValue"](key=k, value=v) for k, v in (("fps", "29.7"), ("é", ""))])]),
        "std_msgs/msg/String": t["std_msgs/msg/String"](data="detected: cup, bottle"),
    }


MSGTYPES = ["sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage", "sensor_msgs/msg/PointCloud2",
            "sensor_msgs/msg/CameraInfo", DetectedObject2DArray.ros_type, "diagnostic_msgs/msg/DiagnosticArray",
            "std_msgs/msg/String"]


@pytest.mark.parametrize("msgtype", MSGTYPES)
def test_rosbags_cdr_round_trips_byte_for_byte(store, msgtype: str) -> None:
    message = _messages(store)[msgtype]
    raw = bytes(store.serialize_cdr(message, msgtype))
    assert raw[:4] == b"\x00\x01\x00\x00"  # XCDR1, little endian: what ROS 2 writes
    dds_type = idl_struct(store, msgtype)
    sample = dds_type.deserialize(raw)
    assert sample.serialize(use_version_2=False) == raw
    if hasattr(message, "header"):
        assert sample.header.frame_id == message.header.frame_id
        assert (sample.header.stamp.sec, sample.header.stamp.nanosec) == (1_700_000_123, 456_789)


def test_field_values_arrive_as_rosbags_wrote_them(store) -> None:
    messages = _messages(store)
    image = messages["sensor_msgs/msg/Image"]
    sample = idl_struct(store, "sensor_msgs/msg/Image").deserialize(bytes(store.serialize_cdr(image,
                                                                                            "sensor_msgs/msg/Image")))
    assert (sample.height, sample.width, sample.encoding, sample.step) == (3, 5, "bgr8", 15)
    assert list(sample.data) == image.data.tolist()
    info = messages["sensor_msgs/msg/CameraInfo"]
    sample = idl_struct(store, "sensor_msgs/msg/CameraInfo").deserialize(
        bytes(store.serialize_cdr(info, "sensor_msgs/msg/CameraInfo")))
    assert list(sample.k) == info.k.tolist() and list(sample.p) == info.p.tolist()
    assert list(sample.d) == info.d.tolist()
    assert (sample.roi.width, sample.roi.do_rectify) == (4, True)
    detections = messages[DetectedObject2DArray.ros_type]
    sample = idl_struct(store, DetectedObject2DArray.ros_type).deserialize(
        bytes(store.serialize_cdr(detections, DetectedObject2DArray.ros_type)))
    assert [o.name for o in sample.objects] == ["cup", "bottle with a long label", ""]
    assert [(p.x, p.y) for p in sample.objects[1].polygon.points] == [(0.0, 0.0), (1.0, 0.5), (2.0, 1.0),
                                                                      (3.0, 1.5)]


def test_samples_built_field_by_field_serialize_as_rosbags(store) -> None:
    image_type = idl_struct(store, "sensor_msgs/msg/Image")
    header_type = idl_struct(store, "std_msgs/msg/Header")
    time_type = idl_struct(store, "builtin_interfaces/msg/Time")
    sample = image_type(header=header_type(stamp=time_type(sec=7, nanosec=9), frame_id="cam"), height=1, width=2,
                        encoding="mono8", is_bigendian=0, step=2, data=[200, 17])
    message = _messages(store)["sensor_msgs/msg/Image"]
    message.header.stamp.sec, message.header.stamp.nanosec, message.header.frame_id = 7, 9, "cam"
    message.height, message.width, message.encoding, message.step = 1, 2, "mono8", 2
    message.data = np.array([200, 17], dtype=np.uint8)
    assert sample.serialize(use_version_2=False) == bytes(store.serialize_cdr(message, "sensor_msgs/msg/Image"))
    text = idl_struct(store, "std_msgs/msg/String")(data="ünïcode ✓")
    expected = store.serialize_cdr(store.types["std_msgs/msg/String"](data="ünïcode ✓"), "std_msgs/msg/String")
    assert text.serialize(use_version_2=False) == bytes(expected)


def test_types_carry_ros2s_dds_names_and_are_made_once_per_typestore(store) -> None:
    image_type = idl_struct(store, "sensor_msgs/msg/Image")
    assert image_type.__idl_typename__ == "sensor_msgs::msg::dds_::Image_"
    assert idl_struct(store, "std_msgs/msg/Header").__idl_typename__ == "std_msgs::msg::dds_::Header_"
    assert idl_struct(store, "sensor_msgs/msg/Image") is image_type
    assert idl_struct(standard_typestore(2), "sensor_msgs/msg/Image") is not image_type


def test_an_unknown_type_is_one_line(store) -> None:
    with pytest.raises(LiveError, match=r"^ros2: type vision_msgs/msg/Detection2DArray is not known"):
        idl_struct(store, "vision_msgs/msg/Detection2DArray")
