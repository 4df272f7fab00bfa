"""TCPROS framing: connection headers and length-prefixed messages, read with bounds and deadlines.

A connection header is a 4-byte little-endian length followed by fields, each a 4-byte little-endian length
and ``key=value``; a message is a 4-byte little-endian length and its ROS 1 serialization. A peer decides
those lengths, so every read is bounded: a header over :data:`MAX_HEADER_BYTES` or a message over
:data:`LIVE_MESSAGE_BYTES` is refused before anything is allocated, and a message's buffer grows only as its
bytes actually arrive. Every socket has a timeout; a header must be complete within its deadline.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from collections.abc import Mapping

from strictio.limits import LIVE_MESSAGE_BYTES

from ..transport import LiveError

#: The largest connection header taken from a peer (real ones are a few kilobytes: the message definition).
MAX_HEADER_BYTES = 64 * 1024
#: How long a peer may take to send its whole connection header.
HEADER_DEADLINE = 10.0
#: How long a message may stall half-way before the connection is dropped.
STALL_DEADLINE = 30.0
#: Socket timeout of every TCPROS socket: how often a blocked read looks whether it should stop.
POLL_SECONDS = 0.5
# Read big messages in pieces of at most this, so memory follows the bytes that came, not the length claimed.
_CHUNK = 4 * 1024 * 1024
_LENGTH = struct.Struct("<I")


class TcprosError(LiveError):
    """A peer that broke the protocol or a bound; the connection is dropped."""


class Stopped(Exception):
    """The reader was asked to stop while waiting."""


def encode_header(fields: Mapping[str, str]) -> bytes:
    """A connection header of ``fields``, framed."""
    body = b"".join(_LENGTH.pack(len(item)) + item
                    for item in (f"{key}={value}".encode() for key, value in fields.items()))
    return _LENGTH.pack(len(body)) + body


def decode_header(body: bytes, where: str) -> dict[str, str]:
    """The fields of a header's body (without its own length); TcprosError naming ``where`` when malformed."""
    fields: dict[str, str] = {}
    offset = 0
    while offset < len(body):
        if offset + 4 > len(body):
            raise TcprosError(f"{where}: connection header cut inside a field length")
        (size,) = _LENGTH.unpack_from(body, offset)
        offset += 4
        if size > len(body) - offset:
            raise TcprosError(f"{where}: connection header field of {size} bytes runs past the header")
        item = body[offset:offset + size].decode("utf-8", "replace")
        offset += size
        key, sep, value = item.partition("=")
        if not sep:
            raise TcprosError(f"{where}: connection header field without '=': {item[:60]!r}")
        fields[key] = value
    return fields


def frame(raw: bytes) -> bytes:
    """``raw`` with its length prefix, as it goes on the wire."""
    return _LENGTH.pack(len(raw)) + raw


def _read_into(sock: socket.socket, view: memoryview, deadline: float | None, stop: threading.Event | None,
               where: str) -> None:
    """Fill ``view`` from ``sock``: ConnectionError at end of stream, TcprosError past ``deadline``
    (monotonic) or when no byte came for :data:`STALL_DEADLINE` s, Stopped when ``stop`` is set."""
    got = 0
    last_progress = time.monotonic()
    while got < len(view):
        if stop is not None and stop.is_set():
            raise Stopped
        try:
            n = sock.recv_into(view[got:])
        except TimeoutError:
            now = time.monotonic()
            if deadline is not None and now > deadline:
                raise TcprosError(f"{where}: peer too slow, {got} of {len(view)} bytes in time") from None
            if got and now - last_progress > STALL_DEADLINE:
                raise TcprosError(f"{where}: peer stalled after {got} of {len(view)} bytes") from None
            continue
        if n == 0:
            raise ConnectionError(f"{where}: connection closed")
        got += n
        last_progress = time.monotonic()
        if deadline is not None and last_progress > deadline and got < len(view):
            raise TcprosError(f"{where}: peer too slow, {got} of {len(view)} bytes in time")


def _read_length(sock: socket.socket, deadline: float | None, stop: threading.Event | None, where: str) -> int:
    prefix = bytearray(4)
    _read_into(sock, memoryview(prefix), deadline, stop, where)
    return _LENGTH.unpack(prefix)[0]


def read_header(sock: socket.socket, where: str, stop: threading.Event | None = None,
                timeout: float | None = None) -> dict[str, str]:
    """A whole connection header within ``timeout`` s (default :data:`HEADER_DEADLINE`); TcprosError for one
    over :data:`MAX_HEADER_BYTES`."""
    deadline = time.monotonic() + (HEADER_DEADLINE if timeout is None else timeout)
    size = _read_length(sock, deadline, stop, where)
    if size > MAX_HEADER_BYTES:
        raise TcprosError(f"{where}: connection header of {size:,} bytes, over the limit of {MAX_HEADER_BYTES:,}")
    body = bytearray(size)
    _read_into(sock, memoryview(body), deadline, stop, where)
    return decode_header(bytes(body), where)


def read_message(sock: socket.socket, where: str, stop: threading.Event | None = None) -> bytes:
    """The next message's bytes (waiting as long as it takes for it to start; ``stop`` ends the wait);
    TcprosError for a length over :data:`LIVE_MESSAGE_BYTES`, refused before anything is allocated."""
    size = _read_length(sock, None, stop, where)
    limit = LIVE_MESSAGE_BYTES.value()
    if size > limit:
        raise TcprosError(f"{where}: message of {size:,} bytes, over the limit of {limit:,} bytes"
                          f" (set {LIVE_MESSAGE_BYTES.variable} to raise it)")
    if size <= _CHUNK:
        body = bytearray(size)
        _read_into(sock, memoryview(body), None, stop, where)
        return bytes(body)
    pieces = bytearray()
    while len(pieces) < size:
        piece = bytearray(min(_CHUNK, size - len(pieces)))
        _read_into(sock, memoryview(piece), None, stop, where)
        pieces += piece
    return bytes(pieces)


def connect(host: str, port: int, timeout: float) -> socket.socket:
    """A TCP connection to ``host:port`` (``timeout`` to connect), then polling reads, no Nagle delay."""
    sock = socket.create_connection((host, port), timeout=timeout)
    sock.settimeout(POLL_SECONDS)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock
