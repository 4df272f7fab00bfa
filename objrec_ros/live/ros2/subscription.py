"""One ROS 2 topic subscribed over DDS: a DataReader whose listener puts each sample's bytes in a slot.

The reader is made once the topic's type is known: given by the caller, or found from discovery (a
source that names only a topic waits for its publisher, within its deadline). DDS itself rematches a
writer that goes away and comes back, so nothing else is needed for a restarted camera node.
"""

from __future__ import annotations

import logging
import threading
import time

from cyclonedds.core import Listener
from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from rosbags.typesys.store import Typestore

from ..slot import NewestSlot, SlotSubscription
from ..transport import LiveError, LiveMessage
from .dds_types import idl_struct
from .discovery import Publications
from .entities import delete_entity
from .qos import reader_qos, type_hash_user_data
from .wire import take_raw

log = logging.getLogger(__name__)


class Ros2Subscription(SlotSubscription):
    """The newest sample of one ROS 2 topic; see :class:`objrec_ros.live.transport.Subscription`."""

    def __init__(self, participant: DomainParticipant, publications: Publications, topic: str, dds_name: str,
                 msgtype: str | None, typestore: Typestore, reliable: bool, domain: int) -> None:
        self.topic = topic
        self._participant = participant
        self._publications = publications
        self._dds_name = dds_name
        self._typestore = typestore
        self._reliable = reliable
        self._domain = domain
        self._slot: NewestSlot[LiveMessage] = NewestSlot()
        self._lock = threading.Lock()
        self._msgtype: str | None = None
        self._reader: DataReader | None = None
        self._topic_entity: Topic | None = None
        self._closed = False
        if msgtype is not None:
            self._open_reader(msgtype)

    # -- the type, and the reader made with it -------------------------------------------------------------
    def wait_type(self, timeout: float) -> str:
        types = self._publications.type_of(self.topic, timeout, lambda: self._closed)
        if not types:
            live = ", ".join(f"{t.name} ({t.msgtype})" for t in self._publications.now()) or "none"
            raise LiveError(f"ros2: no publisher of {self.topic} appeared within {timeout:g} s on domain "
                            f"{self._domain}; live topics: {live}")
        if self._msgtype is not None:
            if self._msgtype not in types:  # DDS matches by type name: these writers are never heard
                raise LiveError(f"ros2: {self.topic} is published as {', '.join(types)}, not as {self._msgtype}")
            return self._msgtype
        known = [t for t in types if t in self._typestore.fielddefs]
        if not known:
            raise LiveError(f"ros2: {self.topic} is published as {', '.join(types)}, a type objrec does not know")
        if len(types) > 1:
            log.warning("ros2: %s is published with several types (%s); subscribing as %s",
                        self.topic, ", ".join(types), known[0])
        self._open_reader(known[0])
        if self._msgtype is None:
            raise LiveError(f"ros2: the subscription to {self.topic} is closed")
        return self._msgtype

    def _open_reader(self, msgtype: str) -> None:
        with self._lock:
            if self._reader is not None or self._closed:
                return
            data_type = idl_struct(self._typestore, msgtype)
            self._topic_entity = Topic(self._participant, self._dds_name, data_type)
            qos = reader_qos(self._reliable, type_hash_user_data(self._typestore, msgtype))
            listener = Listener(on_data_available=self._on_data)
            self._data_type = data_type
            self._msgtype = msgtype
            self._reader = DataReader(self._participant, self._topic_entity, qos=qos, listener=listener)
            self._listener = listener
        log.debug("ros2: subscribed to %s (%s) as DDS topic %s", self.topic, msgtype, self._dds_name)

    def _on_data(self, reader: DataReader) -> None:
        """Runs on a cyclonedds thread: move every waiting sample into the slot (the last one stays)."""
        try:
            for raw in take_raw(reader, self._data_type):
                assert self._msgtype is not None
                self._slot.put(LiveMessage(self.topic, self._msgtype, raw, time.time_ns()))
        except Exception:  # a listener must not raise into cyclonedds' thread
            log.exception("ros2: taking a sample of %s failed", self.topic)

    # -- messages ------------------------------------------------------------------------------------------
    def next(self, timeout: float | None) -> LiveMessage | None:
        if self._reader is None:
            started = time.monotonic()
            wait = float("inf") if timeout is None else timeout
            if not self._publications.type_of(self.topic, wait, lambda: self._closed) or self._closed:
                return None
            if self._reader is None:
                self.wait_type(0.0)
            if timeout is not None:
                timeout = max(0.0, timeout - (time.monotonic() - started))
        return super().next(timeout)

    @property
    def publishers(self) -> int:
        """Writers matched now (0 before the type is known)."""
        if self._reader is None:
            return 0
        return self._reader.get_subscription_matched_status().current_count

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            reader, topic = self._reader, self._topic_entity
            self._reader = self._topic_entity = None
        self._slot.close()
        delete_entity(reader)
        delete_entity(topic)
