"""The one small interface every live transport keeps: topics listed, subscribed and published as raw bytes.

A transport (``ros1``: the ROS 1 master and TCPROS; ``ros2``: DDS through cyclonedds; a Zenoh one may follow)
moves serialized messages; it knows message types only as far as it must to talk to its peers (a ROS 1
md5sum and definition, a DDS type). What the bytes mean is the caller's business: the live sources of the
kinds (``objrec2d.live_source``, ``objrec3d.live_source``) deserialize them with rosbags' typestores, and
the live detection output serializes with the same typestore the bag writer uses. So the apps know nothing
of either transport, and a message on the wire is byte for byte what rosbags writes into a bag: ROS 1
serialization for ``ros1``, CDR with its 4-byte encapsulation header for ``ros2``.

Two rules every transport keeps, because a robot's camera does not wait for a slow detector:

- **The newest message wins.** A subscription holds one message; one arriving before the last was taken
  replaces it, and the replaced one is counted in :attr:`Subscription.dropped`. Nothing queues without bound.
- **Every wait has a deadline** and **a publisher never blocks**: a subscriber too slow to take what is
  sent loses messages, the publishing loop does not stall.

Message types are written in rosbags' form (``sensor_msgs/msg/Image``) on this interface whatever the
transport's own spelling (ROS 1 ``sensor_msgs/Image``, DDS ``sensor_msgs::msg::dds_::Image_``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

from rosbags.typesys.store import Typestore


class LiveError(RuntimeError):
    """A live transport that cannot do what was asked: a master that does not answer, a topic that never
    appears within its deadline, a type the peers disagree on. One line, naming the topic or address."""


@dataclass(frozen=True)
class LiveTopic:
    """A topic some node publishes, with its type in rosbags' form (``sensor_msgs/msg/Image``)."""

    name: str
    msgtype: str


@dataclass(frozen=True)
class LiveMessage:
    """One message as it arrived: its topic and type, its bytes (ROS 1 serialization or CDR, as rosbags'
    ``serialize_ros1``/``serialize_cdr`` give), and when it arrived (``time.time_ns()``)."""

    topic: str
    msgtype: str
    raw: bytes
    received_ns: int


class Subscription(ABC):
    """The newest message of one topic, from every publisher of it; see the module docstring.

    A publisher that goes away and comes back (or a new one) is picked up again without the caller's help.
    """

    topic: str

    @abstractmethod
    def wait_type(self, timeout: float) -> str:
        """The topic's type once a publisher of it is known (rosbags' form); LiveError after ``timeout`` s
        naming the topic and what is live instead."""

    @abstractmethod
    def next(self, timeout: float | None) -> LiveMessage | None:
        """The newest message not yet taken, waiting up to ``timeout`` s for one (None: as long as it takes,
        which a caller uses only with a way to stop); None when none arrived in time."""

    @property
    @abstractmethod
    def received(self) -> int:
        """Messages that arrived (taken or dropped)."""

    @property
    @abstractmethod
    def dropped(self) -> int:
        """Messages replaced by a newer one before they were taken."""

    @abstractmethod
    def close(self) -> None:
        """Unsubscribe and release the connections (idempotent)."""


class Publisher(ABC):
    """Sends serialized messages of one type on one topic to every subscriber, never blocking the caller."""

    topic: str
    msgtype: str

    @abstractmethod
    def publish(self, raw: bytes) -> None:
        """Send one message (bytes in this transport's serialization) to the current subscribers."""

    @property
    @abstractmethod
    def subscribers(self) -> int:
        """Subscribers connected now."""

    @abstractmethod
    def close(self) -> None:
        """Unadvertise and close the connections (idempotent)."""


class Transport(ABC):
    """One participant of a ROS 1 or ROS 2 system: lists, subscribes to and publishes topics.

    Opened with the options of a spec (``ros1:``'s ``master``, ``ros2:``'s ``domain``), closed once; every
    subscription and publisher it made is closed with it.
    """

    #: The scheme that names it in source specs and ``--publish`` (``ros1``, ``ros2``).
    scheme: ClassVar[str]
    #: Which serialization its bytes are in: 1 (ROS 1) or 2 (CDR).
    ros_version: ClassVar[int]

    @classmethod
    @abstractmethod
    def open(cls, options: Mapping[str, str], node_name: str = "objrec") -> Transport:
        """Join the system. ``options`` are a spec's texts (``master``, ``domain``; defaults from the
        environment, ``ROS_MASTER_URI``/``ROS_DOMAIN_ID``); LiveError naming the address when it cannot."""

    @abstractmethod
    def topics(self, timeout: float = 2.0) -> list[LiveTopic]:
        """The topics published now, sorted by name (ROS 2: those discovered within ``timeout`` s)."""

    @abstractmethod
    def subscribe(self, topic: str, msgtype: str | None = None, typestore: Typestore | None = None, *,
                  reliable: bool = False) -> Subscription:
        """Subscribe to ``topic`` (its type found from the system when ``msgtype`` is None). ``typestore``
        knows the type (default: the standard types of this ROS version); ``reliable`` asks ROS 2 for
        reliable delivery instead of the sensor-data best effort."""

    @abstractmethod
    def advertise(self, topic: str, msgtype: str, typestore: Typestore, *, reliable: bool = True,
                  latch: bool = False) -> Publisher:
        """Publish ``msgtype`` (known to ``typestore``, which gives its ROS 1 definition and md5sum or its
        DDS type) on ``topic``."""

    @abstractmethod
    def close(self) -> None:
        """Leave the system: every subscription and publisher closed, the node unregistered (idempotent)."""

    def __enter__(self) -> Transport:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
