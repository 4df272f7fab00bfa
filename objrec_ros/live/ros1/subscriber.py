"""A ROS 1 subscription: one TCPROS connection per publisher, the newest message kept, publishers followed.

The master gives the publishers' slave URIs (at registration, then with ``publisherUpdate``); for each, a
link thread asks it ``requestTopic`` for a TCPROS port, connects, exchanges headers (our md5sum, or ``*``
when the caller gave no type: then the publisher's header says the type) and reads messages into the
subscription's one-message slot. A connection that breaks while its publisher is still listed is retried with
backoff, so a publisher that restarts is picked up again; one the master no longer lists is let go.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
import xmlrpc.client
from collections.abc import Callable
from typing import Any

from ..slot import NewestSlot, SlotSubscription
from ..transport import LiveError, LiveMessage
from .master import Master
from .names import from_ros1_type
from .rpc import RpcFailure, call
from .tcpros import Stopped, TcprosError, connect, encode_header, read_header, read_message

log = logging.getLogger(__name__)

#: How long asking a publisher for its port, or connecting to it, may take.
CONNECT_TIMEOUT = 5.0
#: Retry pauses of a broken connection: first, and the most it grows to.
FIRST_RETRY, MAX_RETRY = 0.1, 2.0
#: How often wait_type asks the master while no publisher is known.
_POLL_MASTER = 0.2
_connection_ids = itertools.count(1)


class _TypeConflict(LiveError):
    """A publisher of another type than the subscription's; that publisher is not retried."""


class _Link:
    """The connection to one publisher, kept up by a thread until stopped."""

    def __init__(self, subscription: Ros1Subscription, publisher_uri: str) -> None:
        self.id = next(_connection_ids)
        self.uri = publisher_uri
        self.connected = False
        self.received = 0
        self.bytes_received = 0
        self.stop = threading.Event()
        self._subscription = subscription
        self._thread = threading.Thread(target=self._run, name=f"ros1-sub{subscription.topic}<-{publisher_uri}",
                                        daemon=True)
        self._thread.start()

    def close(self, wait: float = 0.0) -> None:
        self.stop.set()
        if wait:
            self._thread.join(timeout=wait)

    def _run(self) -> None:
        pause = FIRST_RETRY
        sub = self._subscription
        where = f"publisher {self.uri} of {sub.topic}"
        while not self.stop.is_set():
            sock = None
            try:
                protocol = call(self.uri, "requestTopic", sub.caller_id, sub.topic, [["TCPROS"]],
                                timeout=CONNECT_TIMEOUT)
                if not (isinstance(protocol, list) and len(protocol) == 3 and protocol[0] == "TCPROS"):
                    raise TcprosError(f"{where}: requestTopic offered {str(protocol)[:80]}, not TCPROS")
                sock = connect(str(protocol[1]), int(protocol[2]), CONNECT_TIMEOUT)
                sock.sendall(encode_header(sub.connection_header()))
                header = read_header(sock, where, self.stop)
                if "error" in header:
                    raise TcprosError(f"{where} refused us: {header['error'][:200]}")
                sub.accept_header(header, where)
                self.connected = True
                log.debug("connected to %s", where)
                while True:
                    raw = read_message(sock, where, self.stop)
                    pause = FIRST_RETRY  # a working connection: a break of it is retried at once
                    self.received += 1
                    self.bytes_received += len(raw)
                    sub.deliver(raw)
            except Stopped:
                break
            except _TypeConflict as exc:
                log.warning("%s", exc)
                break
            except (OSError, TcprosError, RpcFailure, xmlrpc.client.Error, ValueError) as exc:
                text = str(exc) if isinstance(exc, TcprosError) else f"{where}: {exc}"
                # the first failure in a row is worth the user's attention, its repetitions are not
                log.log(logging.INFO if pause == FIRST_RETRY else logging.DEBUG, "%s; retrying in %.1f s", text,
                        pause)
            except Exception:  # a bug must not silently end the subscription: say it and keep trying
                log.exception("%s: unexpected failure; retrying in %.1f s", where, pause)
            finally:
                self.connected = False
                if sock is not None:
                    sock.close()
            self.stop.wait(pause)
            pause = min(pause * 2, MAX_RETRY)


class Ros1Subscription(SlotSubscription):
    """The newest message of ``topic`` from all its publishers; made by :meth:`Ros1Transport.subscribe`."""

    def __init__(self, topic: str, msgtype: str | None, ros1_type: str, md5sum: str, definition: str,
                 caller_id: str, master: Master, on_close: Callable[[Ros1Subscription], None]) -> None:
        self.topic = topic
        self.caller_id = caller_id
        self.ros1_type = ros1_type  # "*" until a publisher says
        self.md5sum = md5sum  # "*" when any type is taken
        self._asked_type = msgtype
        self._definition = definition
        self._master = master
        self._on_close = on_close
        self._type: str | None = None  # learned from a publisher's header
        self._lock = threading.Lock()
        self._arrived = threading.Condition(self._lock)
        self._slot: NewestSlot[LiveMessage] = NewestSlot()
        self._links: dict[str, _Link] = {}
        self._closed = False

    # -- what the transport and the links call

    def connection_header(self) -> dict[str, str]:
        return {"callerid": self.caller_id, "topic": self.topic, "md5sum": self.md5sum, "type": self.ros1_type,
                "message_definition": self._definition, "tcp_nodelay": "1"}

    def accept_header(self, header: dict[str, str], where: str) -> None:
        """Check a publisher's header: its md5sum equal to ours (unless we take any), its type the one of the
        other publishers; the type is learned from the first."""
        ros1_type = header.get("type", "")
        if not ros1_type or "md5sum" not in header:
            raise TcprosError(f"{where}: header without type or md5sum")
        if self.md5sum != "*" and header["md5sum"] != self.md5sum:
            raise _TypeConflict(f"{where} sends {ros1_type} (md5sum {header['md5sum']}), not "
                                f"{self.ros1_type} (md5sum {self.md5sum}): not subscribed")
        with self._lock:
            if self._type is None:
                self._type = from_ros1_type(ros1_type)
                if not self._definition:
                    self._definition = header.get("message_definition", "")
                self._arrived.notify_all()
            elif self._type != from_ros1_type(ros1_type):
                raise _TypeConflict(f"{where} sends {from_ros1_type(ros1_type)}, other publishers {self._type}")

    def deliver(self, raw: bytes) -> None:
        message = LiveMessage(self.topic, self._type or self._asked_type or "*", raw, time.time_ns())
        with self._lock:
            if self._closed:
                return
        self._slot.put(message)

    def update_publishers(self, uris: list[str], *, add_only: bool = False) -> None:
        """Follow the master's list of publishers: connect to new ones, let go of those gone (unless
        ``add_only``: the list registration returned may be older than a publisherUpdate already applied)."""
        with self._lock:
            if self._closed:
                return
            gone = [] if add_only else [link for uri, link in self._links.items() if uri not in uris]
            for link in gone:
                del self._links[link.uri]
            for uri in uris:
                if uri not in self._links:
                    self._links[uri] = _Link(self, uri)
        for link in gone:
            link.close()

    def stats(self) -> list[Any]:
        """``getBusStats``' entry: [topic, [[id, bytes, messages, drop estimate, connected]...]]."""
        with self._lock:
            links = list(self._links.values())
        return [self.topic, [[link.id, link.bytes_received, link.received, -1, link.connected] for link in links]]

    def info(self) -> list[list[Any]]:
        with self._lock:
            return [[link.id, link.uri, "i", "TCPROS", self.topic, link.connected] for link in self._links.values()]

    # -- the interface

    def wait_type(self, timeout: float) -> str:
        end = time.monotonic() + timeout
        while True:
            with self._lock:
                if self._type is not None:
                    return self._type
            published = dict(self._master.published_topics())
            if self.topic in published and published[self.topic] != "*":
                found = from_ros1_type(published[self.topic])
                if self._asked_type is not None and found != self._asked_type:
                    raise LiveError(f"topic {self.topic} has type {found}, not {self._asked_type}")
                return found
            left = end - time.monotonic()
            if left <= 0:
                listed = ", ".join(f"{name} ({from_ros1_type(kind)})" for name, kind in sorted(published.items()))
                raise LiveError(f"topic {self.topic}: no publisher within {timeout:g} s (ROS master "
                                f"{self._master.uri}); published now: {listed or 'nothing'}")
            with self._lock:
                self._arrived.wait(min(left, _POLL_MASTER))

    @property
    def msgtype(self) -> str | None:
        """The type (rosbags' form): the one asked for, else the publishers' once one is connected."""
        return self._asked_type or self._type

    @property
    def definition(self) -> str:
        """The ROS 1 message definition: the typestore's when a type was asked for, else the one the first
        publisher sent in its connection header ('' until then), for a caller to register an unknown type."""
        return self._definition

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            links = list(self._links.values())
            self._links.clear()
            self._arrived.notify_all()
        self._slot.close()
        for link in links:
            link.stop.set()
        for link in links:
            link.close(wait=CONNECT_TIMEOUT + 1)
        self._on_close(self)
