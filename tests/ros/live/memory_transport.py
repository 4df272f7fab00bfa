"""A test double of a live transport: topics on an in-process bus, no network, no ROS.

It keeps the rules of :mod:`objrec_ros.live.transport` (one-message slot per subscription, newest wins with
``dropped`` counted, deadlines on every wait, a publisher that never blocks) so the live sources and
``--publish`` can be tested without a master or DDS. Two schemes: ``memory`` carries ROS 1 serialization,
``memory2`` CDR (ROS 2). Register them with :func:`install` (a fixture does it); the kinds' live source
classes are registered for those schemes too (``2d.memory``, ``3d.memory``), so ``memory:/camera`` is a
source spec and ``--publish memory:/detections`` a target, as ``ros1:``/``ros2:`` are for real.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any, ClassVar

import pytest
from rosbags.typesys.store import Typestore

from objrec_ros.live import TRANSPORTS
from objrec_ros.live.slot import NewestSlot, SlotSubscription
from objrec_ros.live.transport import LiveError, LiveMessage, LiveTopic, Publisher, Subscription, Transport

_NAME = re.compile(r"^(/[A-Za-z][A-Za-z0-9_]*)+$")


class MemoryBus:
    """Every topic published in this process by a memory transport: its type and its subscriptions."""

    def __init__(self) -> None:
        self.lock = threading.Condition()
        self.types: dict[str, str] = {}
        self.publishers: dict[str, int] = {}
        self.subscriptions: dict[str, list[MemorySubscription]] = {}
        self.transports: list[MemoryTransport] = []
        self.latched: dict[str, LiveMessage] = {}
        #: Every message delivered, by topic (what a test reads: unlike a subscription, it loses none).
        self.sent: dict[str, list[LiveMessage]] = {}

    def deliver(self, topic: str, msgtype: str, raw: bytes, latch: bool = False) -> int:
        message = LiveMessage(topic, msgtype, raw, time.time_ns())
        with self.lock:
            targets = list(self.subscriptions.get(topic, ()))
            if latch:
                self.latched[topic] = message
            self.sent.setdefault(topic, []).append(message)
            self.lock.notify_all()
        for subscription in targets:
            subscription.put(message)
        return len(targets)

    def wait_sent(self, topic: str, count: int, timeout: float) -> list[LiveMessage]:
        """The messages sent on ``topic`` once there are ``count`` (fewer when ``timeout`` s pass first)."""
        end = time.monotonic() + timeout
        with self.lock:
            while len(self.sent.get(topic, ())) < count and time.monotonic() < end:
                self.lock.wait(0.05)
            return list(self.sent.get(topic, ()))

    def live(self) -> str:
        with self.lock:
            return ", ".join(f"{t} ({self.types[t]})" for t in sorted(self.types) if self.publishers.get(t)) or "none"


BUS = MemoryBus()


class MemorySubscription(SlotSubscription):
    def __init__(self, bus: MemoryBus, topic: str, msgtype: str | None) -> None:
        self.bus, self.topic, self.msgtype = bus, topic, msgtype
        self._slot: NewestSlot[LiveMessage] = NewestSlot()  # the transports' own newest-wins slot
        self.closed = False

    def put(self, message: LiveMessage) -> None:
        self._slot.put(message)

    def wait_type(self, timeout: float) -> str:
        end = time.monotonic() + timeout
        with self.bus.lock:
            while not self.bus.publishers.get(self.topic):
                left = end - time.monotonic()
                if left <= 0:
                    raise LiveError(f"no publisher of {self.topic} within {timeout:g} s (live: {self.bus.live()})")
                self.bus.lock.wait(min(left, 0.05))
            return self.bus.types[self.topic]

    def close(self) -> None:
        with self.bus.lock:
            subscriptions = self.bus.subscriptions.get(self.topic, [])
            if self in subscriptions:
                subscriptions.remove(self)
        self.closed = True
        self._slot.close()


class MemoryPublisher(Publisher):
    def __init__(self, bus: MemoryBus, topic: str, msgtype: str, latch: bool) -> None:
        self.bus, self.topic, self.msgtype, self.latch = bus, topic, msgtype, latch
        self.sent = 0
        self.closed = False

    def publish(self, raw: bytes) -> None:
        if self.closed:
            raise LiveError(f"{self.topic}: the publisher is closed")
        self.bus.deliver(self.topic, self.msgtype, bytes(raw), self.latch)
        self.sent += 1

    @property
    def subscribers(self) -> int:
        with self.bus.lock:
            return len(self.bus.subscriptions.get(self.topic, ()))

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        with self.bus.lock:
            self.bus.publishers[self.topic] -= 1
            if not self.bus.publishers[self.topic]:
                self.bus.latched.pop(self.topic, None)
            self.bus.lock.notify_all()


class MemoryTransport(Transport):
    """The test double: ROS 1 bytes on the in-process bus. ``options`` are kept to be checked by tests."""

    scheme: ClassVar[str] = "memory"
    ros_version: ClassVar[int] = 1
    bus: ClassVar[MemoryBus] = BUS

    def __init__(self, options: Mapping[str, str], node_name: str) -> None:
        self.options = dict(options)
        self.node_name = node_name
        self.subscriptions: list[MemorySubscription] = []
        self.publishers: list[MemoryPublisher] = []
        self.closed = False

    @classmethod
    def open(cls, options: Mapping[str, str], node_name: str = "objrec") -> Transport:
        if options.get("master") == "http://unreachable:1/":
            raise LiveError("the master at http://unreachable:1/ does not answer")
        transport = cls(options, node_name)
        with cls.bus.lock:
            cls.bus.transports.append(transport)
        return transport

    def topics(self, timeout: float = 2.0) -> list[LiveTopic]:
        with self.bus.lock:
            return [LiveTopic(t, self.bus.types[t]) for t in sorted(self.bus.types) if self.bus.publishers.get(t)]

    def subscribe(self, topic: str, msgtype: str | None = None, typestore: Typestore | None = None, *,
                  reliable: bool = False) -> Subscription:
        self._check(topic)
        subscription = MemorySubscription(self.bus, topic, msgtype)
        with self.bus.lock:
            self.bus.subscriptions.setdefault(topic, []).append(subscription)
            latched = self.bus.latched.get(topic) if self.bus.publishers.get(topic) else None
        if latched is not None:  # a latched publisher's last message goes to each new subscriber, as in ROS 1
            subscription.put(latched)
        self.subscriptions.append(subscription)
        return subscription

    def advertise(self, topic: str, msgtype: str, typestore: Typestore, *, reliable: bool = True,
                  latch: bool = False) -> Publisher:
        self._check(topic)
        if msgtype not in typestore.fielddefs:
            raise LiveError(f"{topic}: {msgtype} is not known to the typestore given")
        with self.bus.lock:
            if self.bus.types.get(topic, msgtype) != msgtype and self.bus.publishers.get(topic):
                raise LiveError(f"{topic} is published as {self.bus.types[topic]}, not {msgtype}")
            self.bus.types[topic] = msgtype
            self.bus.publishers[topic] = self.bus.publishers.get(topic, 0) + 1
            self.bus.lock.notify_all()
        publisher = MemoryPublisher(self.bus, topic, msgtype, latch)
        self.publishers.append(publisher)
        return publisher

    def _check(self, topic: str) -> None:
        if not _NAME.fullmatch(topic):
            raise LiveError(f"{self.scheme}: {topic!r} is not a valid topic name")

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        for subscription in self.subscriptions:
            subscription.close()
        for publisher in self.publishers:
            publisher.close()


class MemoryTransport2(MemoryTransport):
    """The test double carrying CDR (ROS 2) bytes."""

    scheme: ClassVar[str] = "memory2"
    ros_version: ClassVar[int] = 2


def _live_source_classes() -> dict[str, Any]:
    from objrec2d.live_source import ImageLiveSource
    from objrec3d.live_source import CloudLiveSource

    class MemoryImageSource(ImageLiveSource):
        schemes = ("memory", "memory2")

    class MemoryCloudSource(CloudLiveSource):
        schemes = ("memory", "memory2")

    return {"2d.memory": MemoryImageSource, "3d.memory": MemoryCloudSource}


_SOURCES: dict[str, Any] = {}


#: Python code that runs objrec-detect (``sys.argv[1:]``) in a child process.
DETECT_CHILD = "import sys; from objrec_apps.detect import main; sys.exit(main(sys.argv[1:]))"


@contextmanager
def installed() -> Iterator[MemoryBus]:
    """The memory transports and the kinds' memory sources registered, on an empty bus; removed after
    (every memory transport opened meanwhile is closed)."""
    from objrec_core import register_source
    from objrec_core.registry import unregister_source

    bus = MemoryBus()
    MemoryTransport.bus = bus
    if not _SOURCES:
        _SOURCES.update(_live_source_classes())
    TRANSPORTS.register(MemoryTransport, "memory")
    TRANSPORTS.register(MemoryTransport2, "memory2")
    for name, cls in _SOURCES.items():
        register_source(cls, name)
    try:
        yield bus
    finally:
        for name in _SOURCES:
            unregister_source(name)
        TRANSPORTS.unregister("memory")
        TRANSPORTS.unregister("memory2")
        for transport in list(bus.transports):
            transport.close()


@pytest.fixture
def memory_bus() -> Iterator[MemoryBus]:
    """The memory transports and sources installed for one test (see :func:`installed`)."""
    with installed() as bus:
        yield bus
