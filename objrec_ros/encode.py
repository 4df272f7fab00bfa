"""Typed ROS message bytes from what a run produces: detected-object arrays and annotated pictures.

One home for "detections -> the bytes of a typed message", so that a bag or MCAP file (``objrec_ros.output``)
and a live topic (``objrec-detect --publish``) carry byte for byte the same messages: the array class's
``ros_type`` with its own definitions registered on the standard types of ROS 1 (Noetic) or ROS 2, serialized
by rosbags (``serialize_ros1``, or CDR with its encapsulation header for ROS 2). A ROS 1 subscriber therefore
sees the same md5sum a bag carries, a ROS 2 one the same type name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from rosbags.typesys.store import Typestore

from objrec_core import DetectedObjectArray, Header

from .decode import IMAGE
from .msgdefs import MessageDefinitionError, message_from_dict, register_definitions, standard_typestore

HEADER = "std_msgs/msg/Header"


def array_ros_type(array_type: type[DetectedObjectArray]) -> str:
    """The ROS type an array class declares; MessageDefinitionError where it declares none."""
    ros_type = getattr(array_type, "ros_type", None)
    if not ros_type or not getattr(array_type, "ros_definitions", None):
        raise MessageDefinitionError(f"{array_type.__name__} declares no ros_type and ros_definitions, so its "
                                     "arrays cannot be written as ROS messages")
    return ros_type


def serialize(typestore: Typestore, ros_version: int, message: Any, msgtype: str) -> bytes:
    """``message`` in the serialization of ``ros_version``: ROS 1's, or CDR (little endian) for ROS 2."""
    if ros_version == 1:
        return bytes(typestore.serialize_ros1(message, msgtype))
    return bytes(typestore.serialize_cdr(message, msgtype))


def header_message(typestore: Typestore, header: Header) -> Any:
    """A ``std_msgs/Header`` of this typestore's ROS version (ROS 2's has no seq) from objrec's header."""
    return message_from_dict(typestore, HEADER, header.to_dict())


class DetectionEncoder:
    """Turns detected-object arrays of one class into message bytes of one ROS version.

    ``ros_type`` and ``typestore`` (the standard types plus the array's own) are what a writer or a publisher
    declares for its connection, so the definition it announces is the one the bytes follow.
    """

    def __init__(self, array_type: type[DetectedObjectArray], ros_version: int,
                 typestore: Typestore | None = None) -> None:
        if ros_version not in (1, 2):
            raise ValueError(f"ros_version {ros_version!r}: 1 or 2")
        self.ros_version = ros_version
        self.ros_type = array_ros_type(array_type)
        self.typestore = typestore if typestore is not None else standard_typestore(ros_version)
        register_definitions(self.typestore, self.ros_type, array_type.ros_definitions)

    def __call__(self, array: DetectedObjectArray, header: Mapping[str, Any] | None = None) -> bytes:
        """One array as message bytes; MessageDefinitionError naming the type for a value it cannot hold.
        ``header`` replaces fields of the array's header (``stamp``, ``frame_id``: an input's header copied)."""
        data = array.to_dict()
        if header:
            data["header"] = {**data["header"], **header}
        try:
            message = message_from_dict(self.typestore, self.ros_type, data)
            return serialize(self.typestore, self.ros_version, message, self.ros_type)
        except MessageDefinitionError:
            raise
        except Exception as exc:  # a value the type cannot hold (rosbags' serializers raise struct/Serde errors)
            raise MessageDefinitionError(f"{self.ros_type}: {exc}") from None


class PictureEncoder:
    """Turns pictures (BGR ``uint8`` H x W x 3, or H x W grey) into ``sensor_msgs/Image`` bytes (bgr8 or
    mono8) of one ROS version, under a given header: what ``--publish-annotated`` sends."""

    msgtype = IMAGE

    def __init__(self, ros_version: int) -> None:
        if ros_version not in (1, 2):
            raise ValueError(f"ros_version {ros_version!r}: 1 or 2")
        self.ros_version = ros_version
        self.typestore = standard_typestore(ros_version)

    def __call__(self, picture: np.ndarray, header: Header) -> bytes:
        if picture.dtype != np.uint8 or picture.ndim not in (2, 3) or (picture.ndim == 3 and picture.shape[2] != 3):
            raise ValueError(f"a picture is uint8 H x W x 3 (BGR) or H x W, got {picture.dtype} {picture.shape}")
        height, width = picture.shape[:2]
        channels = 1 if picture.ndim == 2 else 3
        message = self.typestore.types[IMAGE](
            header=header_message(self.typestore, header),
            height=height,
            width=width,
            encoding="mono8" if channels == 1 else "bgr8",
            is_bigendian=0,
            step=width * channels,
            data=np.ascontiguousarray(picture).reshape(-1),
        )
        return serialize(self.typestore, self.ros_version, message, IMAGE)
