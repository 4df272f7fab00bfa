"""One ROS 2 topic published over DDS: a DataWriter fed rosbags' CDR bytes as they are."""

from __future__ import annotations

import logging
import threading

from cyclonedds.core import DDSException
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic
from rosbags.typesys.store import Typestore

from ..transport import LiveError, Publisher
from .dds_types import idl_struct
from .entities import delete_entity
from .qos import type_hash_user_data, writer_qos
from .wire import write_raw

log = logging.getLogger(__name__)

_TIMEOUT = DDSException.DDS_RETCODE_TIMEOUT


class Ros2Publisher(Publisher):
    """Sends CDR bytes of one type on one ROS 2 topic; see :class:`objrec_ros.live.transport.Publisher`.

    A reliable write that would wait longer than the QoS's max blocking time for lagging readers is
    dropped and counted in ``dropped``, never raised: a slow subscriber must not stop detection.
    """

    def __init__(self, participant: DomainParticipant, topic: str, dds_name: str, msgtype: str,
                 typestore: Typestore, reliable: bool, latch: bool) -> None:
        self.topic = topic
        self.msgtype = msgtype
        self.dropped = 0
        self.published = 0
        self._lock = threading.Lock()
        data_type = idl_struct(typestore, msgtype)
        self._topic_entity: Topic | None = Topic(participant, dds_name, data_type)
        qos = writer_qos(reliable, latch, type_hash_user_data(typestore, msgtype))
        self._writer: DataWriter | None = DataWriter(participant, self._topic_entity, qos=qos)
        log.debug("ros2: publishing %s (%s) as DDS topic %s", topic, msgtype, dds_name)

    def publish(self, raw: bytes) -> None:
        with self._lock:
            if self._writer is None:
                raise LiveError(f"ros2: {self.topic}: the publisher is closed")
            try:
                write_raw(self._writer, raw)
            except DDSException as exc:
                if exc.code != _TIMEOUT:
                    raise LiveError(f"ros2: {self.topic}: cannot publish: {exc}") from None
                self.dropped += 1
                return
            self.published += 1

    @property
    def subscribers(self) -> int:
        writer = self._writer
        if writer is None:
            return 0
        return writer.get_publication_matched_status().current_count

    def close(self) -> None:
        with self._lock:
            writer, topic = self._writer, self._topic_entity
            self._writer = self._topic_entity = None
        delete_entity(writer)
        delete_entity(topic)
