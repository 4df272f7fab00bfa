"""objrec-detect's live outputs: the detections (``--publish``) and the annotated picture
(``--publish-annotated``) published on ROS 1 or ROS 2 topics while the run goes on.

``--publish ros1:/detected_objects_2d[,master=URI]`` or ``ros2:/detected_objects_2d[,domain=N]`` (each option
repeatable, together with ``--output`` and the JSON Lines) sends the same typed messages a bag or MCAP output
holds (:class:`objrec_ros.encode.DetectionEncoder`: the same definition and ROS 1 md5sum, the same ROS 2 type
name), stamped with the input frame's header. ``--publish-annotated ros1:/objrec/annotated`` sends each
frame with its detections drawn (``Kind.annotate``, as ``--annotate`` draws it) as a ``sensor_msgs/Image``
(bgr8) under the same header, so rviz or rqt_image_view show what was found; it draws only while somebody
subscribes.

A publisher never blocks detection (the transports' rule: a slow subscriber loses messages); a message that
cannot be sent is logged and the run goes on. A target that cannot be published to (a bad topic name, the
ros2 extra missing, a master that does not answer) is one line, exit 2, before any frame is processed.
Everything of ``objrec_ros`` is imported only when one of these options is given.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from objrec_core import DetectedObjectArray, DetectionDirector, Frame, Kind, SourceError, Stage

from .cli import UserError
from .output_contract import Output, RunEnd
from .outputs import check_topic, require_rosbags

log = logging.getLogger(__name__)

PUBLISH_OPTION = "--publish"
ANNOTATED_OPTION = "--publish-annotated"
#: The node name the run's publishers join under (the transports make it unique per process).
NODE_NAME = "objrec_detect"
_FORMS = "ros1:/TOPIC[,master=URI] or ros2:/TOPIC[,domain=N]"


def live_target(text: str, option: str) -> Any:
    """A ``--publish`` argument checked without joining anything: its scheme, a valid topic name, options of
    that scheme (``objrec_ros.live.source.LiveSpec``); one UserError line naming the option otherwise."""
    require_rosbags(option)
    from objrec_core import SourceSpec
    from objrec_ros.live import TRANSPORTS
    from objrec_ros.live.source import LiveSource, live_spec

    spec = SourceSpec.parse(text, set(TRANSPORTS.names()))
    if spec.scheme is None:
        raise UserError(f"{option} {text}: not a live topic ({_FORMS})")
    if "timeout" in spec.options:
        raise UserError(f"{option} {text}: timeout= is for a live source; a publisher does not wait")
    try:
        target = live_spec(spec, LiveSource.typed_options(spec))
    except SourceError as exc:
        raise UserError(f"{option} {exc}") from None
    check_topic(target.topic, f"{option} {text}")
    return target


class LivePublication(Output):
    """One topic published on a live system for the run: the transport joined and the topic advertised by
    the constructor, both left by ``close``. Counts what went out and the most subscribers seen."""

    #: What it sends, for its summary line.
    noun = "messages"

    def __init__(self, text: str) -> None:
        super().__init__(None)  # no file: nothing of a failed write is this output's
        from objrec_ros.live.source import join

        self.target = live_target(text, self.option)
        self.count = 0
        self.failures = 0
        self.most_subscribers = 0
        try:
            self.transport = join(self.target, NODE_NAME)
        except SourceError as exc:
            raise UserError(f"{self.option} {exc}") from None
        try:
            self.publisher = self._advertise()
        except BaseException:
            self.transport.close()
            raise

    def _advertise(self) -> Any:
        """The publisher of this output's message type on the target topic."""
        raise NotImplementedError

    def advertise(self, msgtype: str, typestore: Any) -> Any:
        from objrec_ros.live import LiveError

        try:
            return self.transport.advertise(self.target.topic, msgtype, typestore, reliable=True)
        except LiveError as exc:
            raise UserError(f"{self.option} {self.target.text}: {exc}") from None

    def send(self, raw: bytes) -> None:
        """Publish one message; a failure is logged (the first, then every 100th) and detection goes on."""
        from objrec_ros.live import LiveError

        try:
            self.publisher.publish(raw)
        except LiveError as exc:
            self.failures += 1
            if self.failures % 100 == 1:
                log.warning("%s %s: a message was not sent (%d so far): %s", self.option, self.target.text,
                            self.failures, exc)
            return
        self.count += 1
        self.most_subscribers = max(self.most_subscribers, self.publisher.subscribers)

    def close(self, end: RunEnd) -> None:
        self.transport.close()  # closes the publisher; errors on the way out are the transport's to log

    def summary(self) -> str:
        plural = "" if self.most_subscribers == 1 else "s"
        failed = f" ({self.failures} not sent)" if self.failures else ""
        return (f"{self.count} {self.noun} published on {self.target.text} to {self.most_subscribers} "
                f"subscriber{plural}{failed}")


class LiveDetections(LivePublication):
    """``--publish``: each frame's detected-object array as the typed message a bag output writes."""

    option = PUBLISH_OPTION

    def __init__(self, text: str, array_type: type[DetectedObjectArray], skip_empty: bool = False) -> None:
        self.array_type = array_type
        self.skip_empty = skip_empty
        super().__init__(text)

    def _advertise(self) -> Any:
        from objrec_ros.encode import DetectionEncoder
        from objrec_ros.msgdefs import MessageDefinitionError

        try:
            self.encoder = DetectionEncoder(self.array_type, self.transport.ros_version)
        except MessageDefinitionError as exc:
            raise UserError(f"{self.option} {self.target.text}: these detections cannot be sent as ROS messages: "
                            f"{exc}") from None
        return self.advertise(self.encoder.ros_type, self.encoder.typestore)

    def attach(self, director: DetectionDirector) -> None:
        director.add_sink(self._publish)

    def _publish(self, array: DetectedObjectArray) -> None:
        if self.skip_empty and not array.objects:
            return
        self.send(self.encoder(array))


class LiveAnnotated(LivePublication):
    """``--publish-annotated``: each frame with its detections drawn, as a bgr8 ``sensor_msgs/Image``."""

    option = ANNOTATED_OPTION
    noun = "annotated images"

    def __init__(self, text: str, kind: Kind) -> None:
        self.kind = kind
        self.skipped = 0
        super().__init__(text)

    def _advertise(self) -> Any:
        from objrec_ros.encode import PictureEncoder

        self.encoder = PictureEncoder(self.transport.ros_version)
        return self.advertise(self.encoder.msgtype, self.encoder.typestore)

    def attach(self, director: DetectionDirector) -> None:
        director.add_annotation_sink(self._publish)

    def _publish(self, frame: Frame, objects: DetectedObjectArray, stages: Sequence[Stage] | None) -> None:
        if not self.publisher.subscribers:  # nobody looks: drawing and sending would be work for nothing
            self.skipped += 1
            return
        self.send(self.encoder(self.kind.annotate(frame, objects), objects.header))
