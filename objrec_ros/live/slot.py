"""A one-message slot: the newest message wins, the one it replaces is counted as dropped.

A camera does not wait for a slow detector; queueing its frames would only grow memory and latency. Every
transport delivers messages on threads of its own (a TCPROS connection's reader, a DDS listener); they land
here, and the detector takes the newest when it is ready.
"""

from __future__ import annotations

import threading
import time
from typing import Generic, TypeVar

from .transport import LiveMessage, Subscription

T = TypeVar("T")


class NewestSlot(Generic[T]):
    """Holds at most one item; ``put`` replaces (counting the replaced one), ``take`` waits for one."""

    def __init__(self) -> None:
        self._item: T | None = None
        self._ready = threading.Condition()
        self._closed = False
        self.received = 0
        self.dropped = 0

    def put(self, item: T) -> None:
        with self._ready:
            self.received += 1
            if self._item is not None:
                self.dropped += 1
            self._item = item
            self._ready.notify_all()

    def take(self, timeout: float | None) -> T | None:
        """The item, waiting up to ``timeout`` s (None: until one comes or the slot closes); None if none."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._ready:
            while self._item is None and not self._closed:
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return None
                self._ready.wait(remaining)
            item, self._item = self._item, None
            return item

    def close(self) -> None:
        """Wake every waiter; later takes return what is left, then None at once."""
        with self._ready:
            self._closed = True
            self._ready.notify_all()


class SlotSubscription(Subscription):
    """A subscription whose messages land in one :class:`NewestSlot`: taking and counting are the slot's.

    Every transport's subscription is one; each makes ``self._slot`` in its ``__init__`` and feeds it from its
    own threads, and keeps only what differs (how the type is found, how it connects, how it closes).
    """

    _slot: NewestSlot[LiveMessage]

    def next(self, timeout: float | None) -> LiveMessage | None:
        return self._slot.take(timeout)

    @property
    def received(self) -> int:
        return self._slot.received

    @property
    def dropped(self) -> int:
        return self._slot.dropped
