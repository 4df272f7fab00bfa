"""The ROS 1 transport: one node of a ROS 1 system (master client, slave server, TCPROS), no rospy.

Opening checks the master answers and registers nothing; the slave server starts with the first subscription
or publisher. Closing unregisters everything at the master (each call with its deadline; a failure on the way
out is logged, not raised, so a master that died first does not turn a clean stop into an error).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Mapping
from typing import Any, ClassVar

from rosbags.typesys.store import Typestore

from ...msgdefs import standard_typestore
from ..transport import LiveError, LiveTopic, Transport
from .master import Master, master_uri
from .names import caller_id, from_ros1_type, to_ros1_type, topic_name
from .publisher import Ros1Publisher
from .slave import Slave, advertised_host
from .subscriber import Ros1Subscription

log = logging.getLogger(__name__)


def _ros1_definition(typestore: Typestore, msgtype: str) -> tuple[str, str]:
    """(definition, md5sum) of ``msgtype`` as ROS 1 has them; LiveError when ``typestore`` does not know it."""
    if msgtype not in typestore.fielddefs:
        raise LiveError(f"message type {msgtype} is not known to the typestore (register its definition first)")
    definition, md5sum = typestore.generate_msgdef(msgtype, ros_version=1)
    return definition, md5sum


class Ros1Transport(Transport):
    """A ROS 1 node talking to the master at the ``master`` option (else ``ROS_MASTER_URI``; other options of
    a spec are not this transport's and are left to its caller). ``reliable`` changes nothing here: TCPROS
    is always reliable, and what a slow reader loses it loses in the subscription's one-message slot."""

    scheme: ClassVar[str] = "ros1"
    ros_version: ClassVar[int] = 1

    def __init__(self, master: Master) -> None:
        self._master = master
        self.caller_id = master.caller_id
        self.master_uri = master.uri
        self.host = advertised_host(master.hostname)
        self._lock = threading.RLock()
        self._slave: Slave | None = None
        self._subscriptions: list[Ros1Subscription] = []
        self._publishers: dict[str, Ros1Publisher] = {}
        self._closed = False

    @classmethod
    def open(cls, options: Mapping[str, str], node_name: str = "objrec") -> Ros1Transport:
        master = Master(master_uri(options), caller_id(node_name))
        master.get_uri()  # LiveError naming the URI when nobody answers
        log.info("ROS 1 node %s joined the master at %s", master.caller_id, master.uri)
        return cls(master)

    # -- the interface

    def topics(self, timeout: float = 2.0) -> list[LiveTopic]:
        return sorted((LiveTopic(name, from_ros1_type(kind)) for name, kind in self._master.published_topics()),
                      key=lambda t: t.name)

    def subscribe(self, topic: str, msgtype: str | None = None, typestore: Typestore | None = None, *,
                  reliable: bool = False) -> Ros1Subscription:
        name = topic_name(topic)
        if msgtype is None:
            ros1_type, md5sum, definition = "*", "*", ""
        else:
            ros1_type = to_ros1_type(msgtype)
            msgtype = from_ros1_type(ros1_type)
            definition, md5sum = _ros1_definition(typestore or standard_typestore(1), msgtype)
        with self._lock:
            slave = self._ensure_open()
            subscription = Ros1Subscription(name, msgtype, ros1_type, md5sum, definition, self.caller_id,
                                            self._master, self._forget_subscription)
            self._subscriptions.append(subscription)
        try:
            publishers = self._master.register_subscriber(name, ros1_type, slave.uri)
        except LiveError:
            subscription.close()
            raise
        subscription.update_publishers(publishers, add_only=True)
        log.info("subscribed to %s (%s): %d publisher(s)", name, msgtype or "any type", len(publishers))
        return subscription

    def advertise(self, topic: str, msgtype: str, typestore: Typestore, *, reliable: bool = True,
                  latch: bool = False) -> Ros1Publisher:
        name = topic_name(topic)
        ros1_type = to_ros1_type(msgtype)
        msgtype = from_ros1_type(ros1_type)
        definition, md5sum = _ros1_definition(typestore, msgtype)
        with self._lock:
            slave = self._ensure_open()
            if name in self._publishers:
                raise LiveError(f"topic {name} is already advertised by this node ({self.caller_id})")
            try:
                publisher = Ros1Publisher(name, msgtype, ros1_type, md5sum, definition, self.caller_id, self.host,
                                          latch, self._forget_publisher)
            except OSError as exc:
                raise LiveError(self._cannot_listen(exc)) from None
            self._publishers[name] = publisher
        try:
            self._master.register_publisher(name, ros1_type, slave.uri)
        except LiveError:
            publisher.close()
            raise
        log.info("advertised %s (%s)%s", name, msgtype, ", latched" if latch else "")
        return publisher

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            subscriptions = list(self._subscriptions)
            publishers = list(self._publishers.values())
        for subscription in subscriptions:
            subscription.close()
        for publisher in publishers:
            publisher.close()
        with self._lock:
            slave, self._slave = self._slave, None
        if slave is not None:
            slave.close()
        log.info("ROS 1 node %s left", self.caller_id)

    # -- bookkeeping

    def _ensure_open(self) -> Slave:
        if self._closed:
            raise LiveError(f"ROS 1 node {self.caller_id} is closed")
        if self._slave is None:
            try:
                self._slave = Slave(self, self.host)
            except OSError as exc:
                raise LiveError(self._cannot_listen(exc)) from None
        return self._slave

    def _cannot_listen(self, exc: OSError) -> str:
        return (f"ROS 1 node {self.caller_id} cannot listen on {self.host} ({exc.strerror or exc}): is ROS_IP or "
                "ROS_HOSTNAME an address of this host?")

    def _forget_subscription(self, subscription: Ros1Subscription) -> None:
        with self._lock:
            if subscription in self._subscriptions:
                self._subscriptions.remove(subscription)
            still = any(s.topic == subscription.topic for s in self._subscriptions)
            slave = self._slave
        if not still and slave is not None:
            self._unregister("unregister_subscriber", subscription.topic, slave.uri)

    def _forget_publisher(self, publisher: Ros1Publisher) -> None:
        with self._lock:
            if self._publishers.get(publisher.topic) is publisher:
                del self._publishers[publisher.topic]
            slave = self._slave
        if slave is not None:
            self._unregister("unregister_publisher", publisher.topic, slave.uri)

    def _unregister(self, method: str, topic: str, slave_uri: str) -> None:
        try:
            getattr(self._master, method)(topic, slave_uri)
        except LiveError as exc:
            log.warning("leaving %s: %s", topic, exc)

    # -- what the slave asks (see slave.NodeHooks)

    def subscriptions(self) -> list[list[str]]:
        with self._lock:
            return [list(pair) for pair in sorted({(s.topic, s.ros1_type) for s in self._subscriptions})]

    def publications(self) -> list[list[str]]:
        with self._lock:
            return [[p.topic, p.ros1_type] for p in self._publishers.values()]

    def publisher_update(self, topic: str, publishers: list[str]) -> None:
        with self._lock:
            subscriptions = [s for s in self._subscriptions if s.topic == topic]
        for subscription in subscriptions:
            subscription.update_publishers(publishers, add_only=True)

    def request_topic(self, topic: str, protocols: list[Any]) -> list[Any]:
        with self._lock:
            publisher = self._publishers.get(topic)
        if publisher is None:
            return [-1, f"{self.caller_id} does not publish {topic}", []]
        if not any(isinstance(p, list) and p and p[0] == "TCPROS" for p in protocols):
            return [0, "only TCPROS is offered", []]
        return [1, "ready on TCPROS", ["TCPROS", publisher.host, publisher.port]]

    def bus_stats(self) -> list[Any]:
        with self._lock:
            return [[p.stats() for p in self._publishers.values()], [s.stats() for s in self._subscriptions], []]

    def bus_info(self) -> list[Any]:
        with self._lock:
            return [row for p in self._publishers.values() for row in p.info()] + \
                   [row for s in self._subscriptions for row in s.info()]

