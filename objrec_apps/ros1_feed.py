"""One live topic feeding the patrol: a thread takes each message from the transport, decodes it, and posts
it to the robot's :class:`~objrec_apps.ros1_clock.WallClock`, so that what it says is handled on the patrol's
thread. The transport keeps only the newest message of a topic (see :mod:`objrec_ros.live.transport`), which is
what a pose or a battery level wants; the thread takes them as they come so that results are not lost.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from objrec_ros.live import Subscription

from .ros1_clock import WallClock

log = logging.getLogger(__name__)

#: How long one wait for a message lasts, so that closing the feed is noticed soon.
POLL_SECONDS = 0.2


class TopicFeed:
    """Decode every message of ``subscription`` with ``decode`` (raw bytes -> message) and hand it to
    ``deliver`` on the clock's thread. A message that does not decode is logged once per topic and skipped."""

    def __init__(self, subscription: Subscription, decode: Callable[[bytes], Any], deliver: Callable[[Any], None],
                 clock: WallClock) -> None:
        self.subscription = subscription
        self._decode = decode
        self._deliver = deliver
        self._clock = clock
        self._stop = threading.Event()
        self._warned = False
        self.messages = 0
        self._thread = threading.Thread(target=self._run, name=f"feed {subscription.topic}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                message = self.subscription.next(POLL_SECONDS)
            except Exception as exc:  # a closed or failed subscription ends the feed, never the patrol
                if not self._stop.is_set():
                    log.warning("%s: %s; no more messages from it", self.subscription.topic, exc)
                return
            if message is None:
                continue
            try:
                decoded = self._decode(message.raw)
            except Exception as exc:  # rosbags' deserializers raise their own errors on bad bytes
                if not self._warned:
                    log.warning("%s: a message of %s cannot be decoded (%s); skipping such messages",
                                message.topic, message.msgtype, exc)
                    self._warned = True
                continue
            self.messages += 1
            self._clock.post(lambda m=decoded: self._deliver(m))

    def close(self) -> None:
        """Stop the thread (the subscription is closed by its transport)."""
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=2 * POLL_SECONDS + 1.0)
