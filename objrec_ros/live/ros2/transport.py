"""The ``ros2`` transport: one DDS participant speaking to a ROS 2 system as a default installation does.

ROS 2 nodes talk DDS (rmw_cyclonedds, rmw_fastrtps), so objrec joins with cyclonedds alone: topics and
types spelled as ROS 2 spells them on DDS (:mod:`.naming`), types made from rosbags' definitions
(:mod:`.dds_types`), the QoS ROS 2 users expect (:mod:`.qos`), and the bytes rosbags reads and writes
(:mod:`.wire`). cyclonedds is the ``ros2`` extra and is imported only when a transport is opened.

Network settings stay the user's: the domain id comes from the ``domain`` option or ``ROS_DOMAIN_ID``,
and cyclonedds reads ``CYCLONEDDS_URI`` for interfaces, multicast and peers (see docs/ros.md).
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

from rosbags.typesys.store import Typestore

from ...msgdefs import standard_typestore
from ..transport import LiveError, LiveTopic, Publisher, Subscription, Transport
from .naming import dds_topic, dds_type, fully_qualified

if TYPE_CHECKING:
    from .discovery import Publications

log = logging.getLogger(__name__)

NEEDS_EXTRA = "ros2: needs the ros2 extra: pip install 'objrec[ros2]'"
#: The largest domain id DDS's default port mapping allows (7400 + 250 * 232 + ... < 65536).
MAX_DOMAIN = 232


def domain_of(options: Mapping[str, str], environ: Mapping[str, str] = os.environ) -> int:
    """The domain id: option ``domain``, else ``ROS_DOMAIN_ID``, else 0; LiveError naming a bad value."""
    for where, text in (("domain", options.get("domain")), ("ROS_DOMAIN_ID", environ.get("ROS_DOMAIN_ID"))):
        if text is None or (where == "ROS_DOMAIN_ID" and not text.strip()):
            continue
        try:
            domain = int(text.strip())
        except ValueError:
            domain = -1
        if not 0 <= domain <= MAX_DOMAIN:
            raise LiveError(f"ros2: {where} {text!r} is not a domain id (a whole number from 0 to {MAX_DOMAIN})")
        return domain
    return 0


class Ros2Transport(Transport):
    """A ROS 2 system on one DDS domain; see :class:`objrec_ros.live.transport.Transport`."""

    scheme: ClassVar[str] = "ros2"
    ros_version: ClassVar[int] = 2

    def __init__(self, domain: int, node_name: str, participant: Any, publications: Publications) -> None:
        self.domain = domain
        self.node_name = node_name
        self._participant = participant
        self._publications = publications
        self._lock = threading.Lock()
        self._subscriptions: list[Subscription] = []
        self._publishers: list[Publisher] = []
        self._closed = False

    @classmethod
    def open(cls, options: Mapping[str, str], node_name: str = "objrec") -> Ros2Transport:
        domain = domain_of(options)
        try:
            from cyclonedds.core import DDSException
            from cyclonedds.domain import DomainParticipant

            from .discovery import Publications
        except ImportError:
            raise LiveError(NEEDS_EXTRA) from None
        try:
            participant = DomainParticipant(domain)
        except DDSException as exc:
            raise LiveError(f"ros2: cannot join DDS domain {domain}: {exc} (check CYCLONEDDS_URI: "
                            f"{os.environ.get('CYCLONEDDS_URI', 'not set')!r})") from None
        log.info("ros2: joined DDS domain %d as %s", domain, node_name)
        return cls(domain, node_name, participant, Publications(participant))

    def _check_open(self) -> None:
        if self._closed:
            raise LiveError(f"ros2: the transport on domain {self.domain} is closed")

    def topics(self, timeout: float = 2.0) -> list[LiveTopic]:
        self._check_open()
        return self._publications.listing(timeout)

    def subscribe(self, topic: str, msgtype: str | None = None, typestore: Typestore | None = None, *,
                  reliable: bool = False) -> Subscription:
        from .subscription import Ros2Subscription

        self._check_open()
        name = fully_qualified(topic, self.node_name)
        if msgtype is not None:
            dds_type(msgtype)  # a bad type name is refused before anything is made
        subscription = Ros2Subscription(self._participant, self._publications, name, dds_topic(name, self.node_name),
                                        msgtype, typestore or standard_typestore(2), reliable, self.domain)
        with self._lock:
            self._subscriptions.append(subscription)
        return subscription

    def advertise(self, topic: str, msgtype: str, typestore: Typestore, *, reliable: bool = True,
                  latch: bool = False) -> Publisher:
        from .publisher import Ros2Publisher

        self._check_open()
        name = fully_qualified(topic, self.node_name)
        dds_type(msgtype)
        publisher = Ros2Publisher(self._participant, name, dds_topic(name, self.node_name), msgtype, typestore,
                                  reliable, latch)
        with self._lock:
            self._publishers.append(publisher)
        return publisher

    def close(self) -> None:
        from .entities import delete_entity

        with self._lock:
            if self._closed:
                return
            self._closed = True
            owned: list[Subscription | Publisher] = [*self._subscriptions, *self._publishers]
            self._subscriptions.clear()
            self._publishers.clear()
        for entity in owned:
            entity.close()
        self._publications.close()
        delete_entity(self._participant)
        log.info("ros2: left DDS domain %d", self.domain)
