"""A Foxglove live view of a running command (``--foxglove [HOST:]PORT``, the ``viz`` extra).

One WebSocket server per command, made with ``foxglove-sdk``; objrec-patrol, objrec-inspect and objrec-detect
all start theirs here, so the address grammar, the install hint and the two rules below live in one place.
This module imports nothing of ``objrec_*`` (the patrol's package may not) and foxglove-sdk only when a
server is started, so it loads without the extra.

- **Bound to 127.0.0.1 unless a host is given**: ``--foxglove 8765`` is seen by this machine only;
  ``--foxglove 0.0.0.0:8765`` (or the robot's own address) lets a laptop on the robot's network connect.
  Port 0 takes a free one; the address actually bound is what :attr:`LiveServer.url` says.
- **It never blocks the command**: logging puts a message into each subscribed client's queue of
  :data:`BACKLOG` messages and returns; when a viewer reads slower than the command logs, its oldest messages
  are dropped (the SDK's ``message_backlog_size``), so a slow or stalled viewer loses frames and the robot
  goes on. Nothing is encoded for a channel nobody subscribes to (:meth:`LiveServer.wanted`).

The server speaks the Foxglove WebSocket protocol under the subprotocol name ``foxglove.sdk.v1`` (the SDK
refuses the older name ``foxglove.websocket.v1``, with which the protocol is identical).

A live WebSocket has no latched topics: a viewer that connects after the map was sent would never see it.
:meth:`LiveServer.latch` keeps the last message of such a channel and sends it again whenever a client
subscribes to it.
"""

from __future__ import annotations

import argparse
import logging
import re
import threading
import time
from dataclasses import dataclass
from typing import Any

from strictio.cli_numbers import Number, NumberError
from strictio.shown import printable

log = logging.getLogger(__name__)

#: The command-line option, in every command that has it.
OPTION = "--foxglove"
INSTALL_HINT = f"{OPTION} needs the viz extra: pip install 'objrec[viz]'"
#: Where the server listens when the option gives no host: this machine only.
DEFAULT_HOST = "127.0.0.1"
#: Messages queued per client before the oldest is dropped (a few frames of images and their stages).
BACKLOG = 64
#: The port the option takes: 0 for a free one.
PORT = Number(0, 65535, whole=True)
HELP = (f"serve a Foxglove live view on [HOST:]PORT (WebSocket; host {DEFAULT_HOST} unless given, 0.0.0.0 for "
        "every interface; port 0 takes a free one); needs objrec[viz]")

_BRACKETED = re.compile(r"\[(?P<host>[^\]]+)\]:(?P<port>.*)")


class FoxgloveUnavailable(RuntimeError):
    """The live view cannot be served as asked: foxglove-sdk is missing or the address cannot be listened on.
    The message is one line for the user (exit code 2)."""


@dataclass(frozen=True)
class Address:
    """Where the server listens."""

    host: str
    port: int

    def __str__(self) -> str:
        return f"[{self.host}]:{self.port}" if ":" in self.host else f"{self.host}:{self.port}"


def parse_address(text: str) -> Address:
    """``PORT``, ``HOST:PORT`` or ``[IPv6]:PORT``; ValueError saying what is wrong (without the option's name)."""
    value = text.strip()
    bracketed = _BRACKETED.fullmatch(value)
    if bracketed:
        host, port_text = bracketed.group("host"), bracketed.group("port")
    elif ":" in value:
        host, _, port_text = value.rpartition(":")
        if ":" in host:
            raise ValueError(f"'{printable(text, 60)}': write an IPv6 host in brackets, [HOST]:PORT")
    else:
        host, port_text = DEFAULT_HOST, value
    if not host:
        raise ValueError(f"'{printable(text, 60)}': no host before the colon; give [HOST:]PORT")
    if not port_text:
        raise ValueError(f"'{printable(text, 60)}': no port after the colon; give [HOST:]PORT")
    try:
        port = int(PORT.parse(port_text))
    except NumberError as exc:
        raise ValueError(f"port {exc}") from None
    return Address(host, port)


def address_type(text: str) -> Address:
    """:func:`parse_address` as an argparse ``type``: a mistake is the parser's one error line, exit 2."""
    try:
        return parse_address(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_foxglove_argument(parser: argparse.ArgumentParser | Any) -> None:
    """The ``--foxglove [HOST:]PORT`` option (on a parser or an argument group)."""
    parser.add_argument(OPTION, type=address_type, metavar="[HOST:]PORT", help=HELP)


def import_foxglove() -> Any:
    """foxglove-sdk, or FoxgloveUnavailable with the install hint."""
    try:
        import foxglove
    except ImportError:
        raise FoxgloveUnavailable(INSTALL_HINT) from None
    return foxglove


def timestamp(ns: int) -> Any:
    """A ``foxglove.messages.Timestamp`` (seconds, nanoseconds) of nanoseconds since the epoch."""
    from foxglove.messages import Timestamp

    return Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


def _resender(server: LiveServer) -> Any:
    """The server's listener: a client subscribing to a latched channel gets its last message again (the SDK's
    ``ServerListener`` gives the other callbacks, which do nothing)."""
    from foxglove.websocket import ServerListener

    class Resender(ServerListener):
        def on_subscribe(self, client: Any, channel: Any) -> None:
            server.resend(channel.id)

    return Resender()


class LiveServer:
    """One Foxglove WebSocket server with its own SDK context, so that two views in one process (tests, an
    app that makes several) never mix their channels."""

    def __init__(self, address: Address, name: str) -> None:
        foxglove = import_foxglove()
        self.address = address
        self.context = foxglove.Context()
        self._latched: dict[int, tuple[Any, Any, int]] = {}
        self._lock = threading.Lock()
        self._closed = False
        try:
            self.server = foxglove.start_server(name=name, host=address.host, port=address.port, context=self.context,
                                                message_backlog_size=BACKLOG, server_listener=_resender(self))
        except Exception as exc:  # the SDK reports an address in use or not assignable as a RuntimeError
            raise FoxgloveUnavailable(f"{OPTION} {address}: cannot listen there: {exc}") from None
        self.port = int(self.server.port)
        log.info("Foxglove live view on %s", self.url)

    @property
    def url(self) -> str:
        """What a viewer connects to (with the port actually bound)."""
        return f"ws://{Address(self.address.host, self.port)}"

    def channel(self, channel_type: Any, topic: str) -> Any:
        """A typed channel (``foxglove.channels.*Channel``) of this server."""
        return channel_type(topic, context=self.context)

    def json_channel(self, topic: str, schema: dict[str, Any]) -> Any:
        """A JSON channel described by a JSON Schema (an object schema with a ``title``)."""
        from foxglove import Channel

        return Channel(topic, schema=schema, context=self.context)

    @staticmethod
    def wanted(channel: Any) -> bool:
        """Whether anyone subscribes to ``channel``: a message nobody reads is not even built."""
        return bool(channel.has_sinks())

    def latch(self, channel: Any, message: Any, log_time: int | None = None) -> None:
        """Log ``message`` now and keep it: a client subscribing later gets it too (a map, the goals)."""
        when = time.time_ns() if log_time is None else log_time
        with self._lock:
            self._latched[channel.id()] = (channel, message, when)
        channel.log(message, log_time=when)

    def resend(self, channel_id: int) -> None:
        """Send a latched channel's last message again (a client just subscribed to it)."""
        with self._lock:
            held = self._latched.get(channel_id)
        if held is not None and not self._closed:
            channel, message, when = held
            channel.log(message, log_time=when)

    def close(self) -> None:
        """Stop serving (clients are disconnected); closing again does nothing."""
        if self._closed:
            return
        self._closed = True
        self.server.stop()
