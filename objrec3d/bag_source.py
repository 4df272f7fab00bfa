"""Point clouds from ROS bags and MCAP files (plug-in ``3d.bag``): ``sensor_msgs/PointCloud2``, or a depth
``sensor_msgs/Image`` with its ``sensor_msgs/CameraInfo`` made into an organized cloud.

``bag:PATH[,topic=NAME,info_topic=NAME,color_topic=NAME,start=S,end=S,rate=R]``, or the plain path of a
``.bag``/``.mcap`` file or a ROS 2 bag folder. Without ``topic`` the only PointCloud2 or depth-image topic is
read. A depth topic (16UC1 or mono16 millimetres, 32FC1 metres) needs intrinsics: ``info_topic``, by default
the only CameraInfo topic (with several, the one in the depth topic's namespace); the newest CameraInfo seen
so far is used for each depth image (the first one of the recording before any arrives). ``color_topic`` (an
Image topic, given explicitly) colours the points: each depth image takes the colour image nearest to it by
header stamp. Back-projection is the RGB-D source's (``rgbd:``), so the same pixels give the same points.
The registry knows this source's forms from :mod:`objrec3d.bag_declaration` and imports this module (and
objrec_ros) only when a spec names a bag.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator
from typing import Any

from objrec_core import SourceSpec, Str
from objrec_ros.bags import TopicInfo, header_frame_id, header_stamp, header_stamp_ns
from objrec_ros.decode import (
    CAMERA_INFO,
    IMAGE,
    POINT_CLOUD2,
    CloudArrays,
    camera_intrinsics,
    depth_cloud,
    encoding_of,
    image_to_rgb,
    is_depth_encoding,
    pointcloud2_arrays,
)
from objrec_ros.source import BagSource, Decoded, topic_names

from .bag_declaration import CLOUD_BAG
from .cloud import PointCloud

#: Depth encodings a named depth topic may have (mono16 is taken as millimetres, as drivers publish it).
DEPTH_TOPIC_ENCODINGS = ("16uc1", "mono16", "32fc1")
#: Depth images held back waiting for a later colour image, at most (a colour topic that stops must not
#: make the source hoard depth images).
MAX_PENDING = 8


def _namespace(topic: str) -> str:
    return topic.rsplit("/", 1)[0]


def as_point_cloud(arrays: CloudArrays) -> PointCloud:
    return PointCloud(arrays.points, arrays.colors, arrays.width, arrays.height)


def pointcloud2_cloud(message: Any) -> PointCloud:
    """A ``sensor_msgs/PointCloud2`` as a frame (the live source reads it the same way)."""
    return as_point_cloud(pointcloud2_arrays(message))


def depth_image_cloud(depth: Any, info: Any, color: Any = None) -> PointCloud:
    """A depth ``Image`` with its ``CameraInfo`` (and a colour ``Image`` or None) as an organized cloud, as
    both the bag and the live source pair them; DecodeError when they do not fit."""
    rgb = None if color is None else image_to_rgb(color)
    return as_point_cloud(depth_cloud(depth, info, rgb))


def nearest_by_stamp(stamp: float, candidates: Iterable[tuple[float, Any] | None]) -> Any:
    """The message among ``(stamp, message)`` candidates (None ones left out) nearest to ``stamp``, or None:
    the colour image a depth image takes."""
    present = [c for c in candidates if c is not None]
    return min(present, key=lambda c: abs(c[0] - stamp))[1] if present else None


class CloudBagSource(BagSource):
    """The clouds of one topic (or depth + CameraInfo pair) of a ROS 1 bag, ROS 2 bag or MCAP file."""

    kind = "3d"
    options = {  # noqa: RUF012 - declarations, never mutated
        **BagSource.options,
        "info_topic": Str("", "the CameraInfo topic of a depth topic (default: the only one)"),
        "color_topic": Str("", "an Image topic colouring a depth topic's points (default: none)"),
    }
    summary = CLOUD_BAG.summary
    noun = "point-cloud"
    readable_types = "sensor_msgs/PointCloud2, or a depth sensor_msgs/Image with a CameraInfo topic"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> CloudBagSource:
        return cls(cls.recording_path(spec, options), topic=options["topic"], info_topic=options["info_topic"],
                   color_topic=options["color_topic"], start=options["start"], end=options["end"],
                   rate=options["rate"], name=spec.text)

    def __init__(self, path: Any, *, topic: str = "", info_topic: str = "", color_topic: str = "",
                 **options: Any) -> None:
        self._wanted_info, self._wanted_color = info_topic, color_topic
        self.info_topic: str | None = None
        self.color_topic: str | None = None
        self._first_info: Any = None
        super().__init__(path, topic=topic, **options)

    # -- choosing the topics ------------------------------------------------------------------------------
    def _encoding(self, info: TopicInfo) -> str:
        try:
            found = self.recording.first(info.name)
        except Exception:  # an unreadable topic is reported if chosen, not while looking
            return ""
        return encoding_of(found[1]) if found is not None else ""

    def _candidates(self) -> list[TopicInfo]:
        topics = self.recording.topics()
        clouds = [t for t in topics if t.msgtype == POINT_CLOUD2]
        return clouds + [t for t in topics if t.msgtype == IMAGE and is_depth_encoding(self._encoding(t))]

    def _select(self, topic: str) -> TopicInfo:
        topics = self.recording.topics()
        info = self.choose(topic, self._candidates)
        if info.msgtype == POINT_CLOUD2:
            for option, value in (("info_topic", self._wanted_info), ("color_topic", self._wanted_color)):
                if value:
                    raise self.error(f"{option}={value} goes with a depth image topic; {info.name} holds "
                                     "PointCloud2")
            _, message = self.first_message(info.name)
            self.check(info.name, 0, pointcloud2_arrays, message)
            return info
        if info.msgtype != IMAGE:
            raise self.wrong_type(info, self._candidates())
        _, depth = self.first_message(info.name)
        if encoding_of(depth) not in DEPTH_TOPIC_ENCODINGS:
            raise self.error(f"topic {info.name} holds {depth.encoding} images, not depth (16UC1, mono16 or 32FC1; "
                             f"{self.noun} topics: {topic_names(self._candidates())})")
        self.info_topic = self._choose_info(info, topics)
        self.color_topic = self._choose_color(topics)
        _, self._first_info = self.first_message(self.info_topic, windowed=False)
        self.check(self.info_topic, 0, camera_intrinsics, self._first_info)
        color = None
        if self.color_topic is not None:
            _, color_message = self.first_message(self.color_topic, windowed=False)
            color = self.check(self.color_topic, 0, image_to_rgb, color_message)
        self.check(info.name, 0, depth_cloud, depth, self._first_info, color)
        return info

    def _choose_info(self, depth: TopicInfo, topics: list[TopicInfo]) -> str:
        infos = [t for t in topics if t.msgtype == CAMERA_INFO]
        if self._wanted_info:
            chosen = next((t for t in topics if t.name == self._wanted_info), None)
            if chosen is None:
                raise self.error(f"no topic {self._wanted_info} (CameraInfo topics: {topic_names(infos)})")
            if chosen.msgtype != CAMERA_INFO:
                raise self.error(f"info_topic {chosen.name} holds {chosen.msgtype}, not sensor_msgs/CameraInfo")
            return chosen.name
        if not infos:
            raise self.error(f"depth topic {depth.name} needs a sensor_msgs/CameraInfo topic for its intrinsics, "
                             "and the recording has none")
        if len(infos) > 1:
            near = [t for t in infos if _namespace(t.name) == _namespace(depth.name)]
            if len(near) != 1:
                raise self.error(f"several CameraInfo topics ({topic_names(infos)}); choose one with "
                                 "info_topic=NAME")
            infos = near
        return infos[0].name

    def _choose_color(self, topics: list[TopicInfo]) -> str | None:
        if not self._wanted_color:
            return None
        chosen = next((t for t in topics if t.name == self._wanted_color), None)
        if chosen is None:
            images = [t for t in topics if t.msgtype == IMAGE]
            raise self.error(f"no topic {self._wanted_color} (Image topics: {topic_names(images)})")
        if chosen.msgtype != IMAGE:
            raise self.error(f"color_topic {chosen.name} holds {chosen.msgtype}, not sensor_msgs/Image")
        return chosen.name

    # -- the frames -------------------------------------------------------------------------------------
    def _decoded(self) -> Iterator[Decoded]:
        if self.info_topic is None:
            for log_time, message in self.recording.messages(self.topic_info.name, self.start, self.end):
                cloud = pointcloud2_cloud(message)
                yield log_time, header_stamp_ns(message, 0), header_frame_id(message), cloud
            return
        yield from self._depth_frames()

    def _depth_frames(self) -> Iterator[Decoded]:
        depth_topic, info_topic, color_topic = self.topic_info.name, self.info_topic, self.color_topic
        info = self._first_info
        pending: deque[tuple[int, Any, Any]] = deque()  # (log time, depth message, its CameraInfo)
        previous: tuple[float, Any] | None = None  # the last colour image seen: (stamp, message)

        def make(log_time: int, depth: Any, depth_info: Any, color: Any) -> Decoded:
            cloud = depth_image_cloud(depth, depth_info, color)
            return log_time, header_stamp_ns(depth, 0), header_frame_id(depth), cloud

        def nearest(stamp: float, later: tuple[float, Any] | None) -> Any:
            return nearest_by_stamp(stamp, (previous, later))

        topics = [t for t in (depth_topic, info_topic, color_topic) if t]
        for topic, log_time, message in self.recording.merged(topics, self.start, self.end):
            if topic == info_topic and topic != depth_topic:
                info = message
            elif topic == depth_topic:
                if color_topic is None:
                    yield make(log_time, message, info, None)
                    continue
                pending.append((log_time, message, info))
                if len(pending) > MAX_PENDING:
                    held = pending.popleft()
                    yield make(*held, nearest(header_stamp(held[1], held[0]), None))
            else:  # a colour image: the depth images up to its stamp take it or the one before
                current = (header_stamp(message, log_time), message)
                while pending and header_stamp(pending[0][1], pending[0][0]) <= current[0]:
                    held = pending.popleft()
                    yield make(*held, nearest(header_stamp(held[1], held[0]), current))
                previous = current
        while pending:
            held = pending.popleft()
            yield make(*held, nearest(header_stamp(held[1], held[0]), None))
