"""A ROS 1 publisher: a TCPROS server socket, one writer thread per subscriber, newest message wins.

A subscriber found through the master asks ``requestTopic`` for our port, connects and sends its header; we
check it wants our type (its md5sum equal to ours, or ``*``), answer with ours (md5sum, type, definition,
latching) and from then on send it messages. Each connection holds one message: :meth:`publish` replaces it
and returns at once, so a slow subscriber loses messages instead of stalling the caller.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import socket
import threading
from collections.abc import Callable
from typing import Any

from strictio.shown import printable

from ..transport import Publisher
from .tcpros import POLL_SECONDS, encode_header, frame, read_header

log = logging.getLogger(__name__)

#: How long one message may take to be sent to a subscriber before it is deemed gone.
SEND_TIMEOUT = 10.0
_connection_ids = itertools.count(1)


class _Outgoing:
    """One subscriber's connection and its one-message slot."""

    def __init__(self, sock: socket.socket, peer: str, callerid: str, topic: str, first: bytes | None,
                 on_end: Callable[[_Outgoing], None]) -> None:
        self.id = next(_connection_ids)
        self.sock = sock
        self.peer = peer
        self.callerid = callerid
        self.sent = 0
        self.bytes_sent = 0
        self._slot = first
        self._wake = threading.Condition()
        self._closed = False
        self._on_end = on_end
        self._thread = threading.Thread(target=self._write, name=f"ros1-pub{topic}->{callerid}", daemon=True)
        self._thread.start()

    def offer(self, raw: bytes) -> None:
        with self._wake:
            self._slot = raw
            self._wake.notify()

    def _write(self) -> None:
        try:
            while True:
                with self._wake:
                    while self._slot is None and not self._closed:
                        self._wake.wait()
                    if self._closed:
                        return
                    raw, self._slot = self._slot, None
                assert raw is not None
                self.sock.sendall(frame(raw))
                self.sent += 1
                self.bytes_sent += len(raw) + 4
        except OSError as exc:
            log.info("subscriber %s (%s) left: %s", self.callerid, self.peer, exc)
        finally:
            self._end()

    def _end(self) -> None:
        with self._wake:
            self._closed = True
            self._wake.notify()
        try:
            self.sock.close()
        finally:
            self._on_end(self)

    def close(self) -> None:
        with self._wake:
            self._closed = True
            self._wake.notify()
        # shutdown wakes a sendall blocked on a full socket buffer
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self._thread.join(timeout=SEND_TIMEOUT + 1)


class Ros1Publisher(Publisher):
    """Publishes ``msgtype`` on ``topic``; made by :meth:`Ros1Transport.advertise`, which registers it."""

    def __init__(self, topic: str, msgtype: str, ros1_type: str, md5sum: str, definition: str, caller_id: str,
                 host: str, latch: bool, on_close: Callable[[Ros1Publisher], None]) -> None:
        self.topic = topic
        self.msgtype = msgtype
        self.ros1_type = ros1_type
        self.md5sum = md5sum
        self.definition = definition
        self.latch = latch
        self._caller_id = caller_id
        self._on_close = on_close
        self._lock = threading.Lock()
        self._connections: list[_Outgoing] = []
        self._last: bytes | None = None
        self._published = 0
        self._closed = threading.Event()
        self._server = socket.create_server((host, 0))
        self._server.settimeout(POLL_SECONDS)
        self.host = host
        self.port: int = self._server.getsockname()[1]
        self._acceptor = threading.Thread(target=self._accept, name=f"ros1-accept{topic}", daemon=True)
        self._acceptor.start()

    # -- the interface

    def publish(self, raw: bytes) -> None:
        with self._lock:
            if self._closed.is_set():
                return
            self._published += 1
            if self.latch:
                self._last = raw
            connections = list(self._connections)
        for connection in connections:
            connection.offer(raw)

    @property
    def subscribers(self) -> int:
        with self._lock:
            return len(self._connections)

    def close(self) -> None:
        if self._closed.is_set():
            return
        self._closed.set()
        self._acceptor.join(timeout=5)
        self._server.close()
        with self._lock:
            connections = list(self._connections)
        for connection in connections:
            connection.close()
        self._on_close(self)

    # -- what the slave asks

    def stats(self) -> list[Any]:
        """``getBusStats``' entry: [topic, bytes sent, [[id, bytes, messages, connected]...]]."""
        with self._lock:
            connections = list(self._connections)
        return [self.topic, sum(c.bytes_sent for c in connections),
                [[c.id, c.bytes_sent, c.sent, True] for c in connections]]

    def info(self) -> list[list[Any]]:
        """``getBusInfo``' entries, one per subscriber."""
        with self._lock:
            return [[c.id, c.callerid, "o", "TCPROS", self.topic, True] for c in self._connections]

    # -- connections

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                sock, address = self._server.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            threading.Thread(target=self._handshake, args=(sock, f"{address[0]}:{address[1]}"),
                             name=f"ros1-handshake{self.topic}", daemon=True).start()

    def _handshake(self, sock: socket.socket, peer: str) -> None:
        where = f"subscriber {peer} of {self.topic}"
        try:
            sock.settimeout(POLL_SECONDS)
            header = read_header(sock, where, self._closed)
            problem = self._refusal(header)
            if problem:
                log.warning("%s refused: %s", where, problem)
                sock.settimeout(SEND_TIMEOUT)
                sock.sendall(encode_header({"error": problem}))
                sock.close()
                return
            sock.settimeout(SEND_TIMEOUT)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.sendall(encode_header({"callerid": self._caller_id, "topic": self.topic, "type": self.ros1_type,
                                        "md5sum": self.md5sum, "message_definition": self.definition,
                                        "latching": "1" if self.latch else "0"}))
        except Exception as exc:  # whatever a peer sends must not kill the node
            if not self._closed.is_set():
                log.info("%s dropped during its header: %s", where, exc)
            sock.close()
            return
        with self._lock:
            if self._closed.is_set():
                sock.close()
                return
            connection = _Outgoing(sock, peer, header.get("callerid", "?"), self.topic, self._last,
                                   self._forget)
            self._connections.append(connection)
        log.debug("%s connected (%s)", where, connection.callerid)

    def _refusal(self, header: dict[str, str]) -> str:
        """Why a subscriber's header is refused ('' when it is accepted)."""
        for field in ("topic", "md5sum", "callerid"):
            if field not in header:
                return f"header has no '{field}' field"
        # what a peer sent is shown escaped and cut, since it goes into our log and its answer
        if header["topic"] != self.topic:
            return f"topic {printable(header['topic'], 80)} is not published here (this is {self.topic})"
        md5sum, wanted = header["md5sum"], header.get("type", "*")
        if md5sum != "*" and md5sum != self.md5sum:
            return (f"client [{printable(header['callerid'], 80)}] wants topic {self.topic} to have datatype/md5sum "
                    f"[{printable(wanted, 80)}/{printable(md5sum, 40)}], but ours is [{self.ros1_type}/{self.md5sum}]")
        if wanted not in ("*", self.ros1_type):
            return f"client wants type {printable(wanted, 80)} on {self.topic}, which has type {self.ros1_type}"
        return ""

    def _forget(self, connection: _Outgoing) -> None:
        with self._lock:
            if connection in self._connections:
                self._connections.remove(connection)
