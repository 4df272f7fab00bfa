"""Point clouds from a live ROS 1 or ROS 2 topic (plug-in ``3d.live``): ``sensor_msgs/PointCloud2``, or a depth
``sensor_msgs/Image`` with its ``sensor_msgs/CameraInfo`` made into an organized cloud.

``ros1:/camera/depth/points`` or ``ros1:/camera/depth/image_raw,info=/camera/depth/camera_info
[,color=/camera/rgb/image_raw]`` (``ros2:`` alike); see :mod:`objrec_ros.live.source` for opening, the
newest-wins loop and the counts. A depth topic's intrinsics come from ``info`` (default: ``camera_info``
beside it, as camera drivers name it); the newest CameraInfo received is used for each depth image. ``color``
colours the points: each depth image takes, among the colour images received lately, the one nearest to it
by header stamp, as the bag source pairs them (:func:`objrec3d.bag_source.nearest_by_stamp`). Decoding is
the bag source's, so a live frame equals the recorded one.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

from objrec_core import SourceSpec, Str
from objrec_ros.bags import header_stamp
from objrec_ros.decode import CAMERA_INFO, IMAGE, POINT_CLOUD2, DecodeError, camera_intrinsics, encoding_of
from objrec_ros.live.source import Deadline, LiveSource, LiveSpec
from objrec_ros.live.transport import Subscription

from .bag_source import DEPTH_TOPIC_ENCODINGS, MAX_PENDING, depth_image_cloud, nearest_by_stamp, pointcloud2_cloud
from .cloud import PointCloud
from .live_declaration import CLOUD_LIVE

#: Seconds a depth image waits for a colour image stamped at or after it, at most (colour and depth of one
#: camera arrive close together; a colour topic that stopped must not slow the clouds down for long).
COLOR_WAIT = 0.05


def _sibling(topic: str, name: str) -> str:
    return f"{topic.rsplit('/', 1)[0]}/{name}"


class CloudLiveSource(LiveSource):
    """The clouds of one live topic (or depth + CameraInfo pair, optionally coloured)."""

    kind = "3d"
    options = {  # noqa: RUF012 - declarations, never mutated
        **LiveSource.options,
        "info": Str("", "a depth topic's CameraInfo topic (default: camera_info beside it)"),
        "color": Str("", "an Image topic colouring a depth topic's points (default: none)"),
    }
    summary = CLOUD_LIVE.summary
    readable = (POINT_CLOUD2, IMAGE)
    readable_text = "point clouds (sensor_msgs/PointCloud2, or a depth Image with a CameraInfo topic)"

    @classmethod
    def extra_options(cls, spec: SourceSpec, options: dict[str, Any]) -> dict[str, Any]:
        return {"info": options["info"], "color": options["color"]}

    def __init__(self, spec: LiveSpec, node_name: str = "objrec", *, info: str = "", color: str = "") -> None:
        self._wanted_info, self._wanted_color = info, color
        self.info_topic: str | None = None
        self.color_topic: str | None = None
        self._info: Any = None
        self._info_subscription: Subscription | None = None
        self._color_subscription: Subscription | None = None
        self._colors: deque[tuple[float, Any]] = deque(maxlen=MAX_PENDING)
        super().__init__(spec, node_name)

    def prepare(self, first: Any, deadline: Deadline) -> None:
        if self.msgtype == POINT_CLOUD2:
            for option, value in (("info", self._wanted_info), ("color", self._wanted_color)):
                if value:
                    raise self.error(f"{option}={value} goes with a depth image topic; {self.topic} holds "
                                     "PointCloud2")
            return
        if encoding_of(first) not in DEPTH_TOPIC_ENCODINGS:
            raise self.error(f"{self.topic} holds {first.encoding} images, not depth (16UC1, mono16 or 32FC1)")
        self.info_topic = _absolute(self._wanted_info) or _sibling(self.topic, "camera_info")
        hint = "" if self._wanted_info else "; give its CameraInfo topic with info=TOPIC"
        try:
            self._info_subscription, _ = self.subscribe(self.info_topic, deadline, (CAMERA_INFO,),
                                                        "camera intrinsics (sensor_msgs/CameraInfo)")
            self._info = self.first_message(self._info_subscription, deadline, "camera intrinsics")
        except Exception as exc:
            raise self.error(f"depth topic {self.topic} needs its CameraInfo: {_reason(exc, self.name)}{hint}") \
                from None
        self._check(camera_intrinsics, self._info, self.info_topic)
        if self._wanted_color:
            self.color_topic = _absolute(self._wanted_color)
            self._color_subscription, _ = self.subscribe(self.color_topic, deadline, (IMAGE,),
                                                         "colour images (sensor_msgs/Image)")
            color = self.first_message(self._color_subscription, deadline, "colour images")
            self._colors.append((header_stamp(color, time.time_ns()), color))

    def _check(self, make: Any, message: Any, topic: str) -> None:
        try:
            make(message)
        except DecodeError as exc:
            raise self.error(f"{topic}: first message: {exc}") from None

    def decode(self, message: Any) -> PointCloud:
        if self.msgtype == POINT_CLOUD2:
            return pointcloud2_cloud(message)
        self._take_info()
        return depth_image_cloud(message, self._info, self._color_for(header_stamp(message, time.time_ns())))

    def _take_info(self) -> None:
        """The newest CameraInfo received so far (a bad one is skipped: the last good one stays)."""
        if self._info_subscription is None:
            return
        live = self._info_subscription.next(0.0)
        if live is not None:
            try:
                self._info = self.read(live)
            except Exception:  # an unreadable CameraInfo: keep the one before
                self.skipped += 1

    def _color_for(self, stamp: float) -> Any:
        subscription = self._color_subscription
        if subscription is None:
            return None
        live = subscription.next(0.0)
        if live is None and (not self._colors or self._colors[-1][0] < stamp):
            live = subscription.next(COLOR_WAIT)  # its colour image may be a moment behind
        if live is not None:
            try:
                color = self.read(live)
                self._colors.append((header_stamp(color, live.received_ns), color))
            except Exception:  # an unreadable colour image: the ones before still serve
                self.skipped += 1
        return nearest_by_stamp(stamp, self._colors)


def _absolute(topic: str) -> str:
    topic = topic.strip()
    return topic if not topic or topic.startswith("/") else f"/{topic}"


def _reason(exc: Exception, name: str) -> str:
    """An error's text without the spec it starts with (the caller names the spec once)."""
    text = str(exc)
    return text[len(name) + 2:] if text.startswith(f"{name}: ") else text
