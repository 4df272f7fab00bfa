"""What is published on the DDS domain, from DDS's own discovery data (the DCPSPublication builtin topic).

DDS has no master to ask: every participant announces its writers, and the builtin topic holds those
heard so far. Discovery takes a moment after joining (on loopback well under a second), so a listing waits
its timeout and a type look-up polls until its deadline. Only ROS 2 topics (``rt/`` with a ROS 2 type
name) are shown, in ROS form; DDS's and ROS 2's own housekeeping topics (``ros_discovery_info``,
``rq/``/``rr/`` services) are left out.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.domain import DomainParticipant

from ..transport import LiveTopic
from .entities import delete_entity
from .naming import ros_topic, ros_type

_POLL = 0.05
_MAX_READ = 4096


class Publications:
    """The live ROS 2 publications of a domain, as one participant has discovered them."""

    def __init__(self, participant: DomainParticipant) -> None:
        self._reader = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        self._alive = ReadCondition(self._reader, SampleState.Any | ViewState.Any | InstanceState.Alive)
        self._lock = threading.Lock()

    def now(self) -> list[LiveTopic]:
        """The ROS 2 topics with at least one live writer, with each writer's type, sorted."""
        with self._lock:
            endpoints = self._reader.read(_MAX_READ, condition=self._alive)
        found = set()
        for endpoint in endpoints:
            name, msgtype = ros_topic(endpoint.topic_name), ros_type(endpoint.type_name)
            if name is not None and msgtype is not None:
                found.add(LiveTopic(name, msgtype))
        return sorted(found, key=lambda t: (t.name, t.msgtype))

    def listing(self, timeout: float) -> list[LiveTopic]:
        """What is live after ``timeout`` s of discovery (DDS cannot say when discovery is complete)."""
        time.sleep(max(0.0, timeout))
        return self.now()

    def type_of(self, topic: str, timeout: float, stopped: Callable[[], bool] = lambda: False) -> list[str]:
        """The types the writers of ``topic`` (ROS form) announce, polling up to ``timeout`` s (or until
        ``stopped()``); [] if none."""
        deadline = time.monotonic() + timeout
        while True:
            types = sorted({t.msgtype for t in self.now() if t.name == topic})
            if types or time.monotonic() >= deadline or stopped():
                return types
            time.sleep(min(_POLL, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Delete the builtin reader (the participant's deletion would too; this keeps the order explicit)."""
        with self._lock:
            delete_entity(self._alive)
            delete_entity(self._reader)
