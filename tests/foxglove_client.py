"""A test client of the Foxglove WebSocket protocol, decoding what a live view sends with the schemas the server
advertises (no protobuf package needed: a small decoder of the protobuf wire format reads the advertised
``FileDescriptorSet`` and then the messages).

The protocol (github.com/foxglove/ws-protocol, docs/spec.md), as foxglove-sdk serves it under the subprotocol
``foxglove.sdk.v1``: the server sends ``serverInfo`` and ``advertise`` (JSON text: channel id, topic, encoding,
schemaName, schemaEncoding, schema); a client sends ``{"op": "subscribe", "subscriptions": [{"id", "channelId"}]}``
and receives binary Message Data frames: opcode 0x01, subscription id (u32 LE), log time (u64 LE ns), payload.
"""

from __future__ import annotations

import asyncio
import base64
import json
import struct
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import websockets

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 0x01

# -- the protobuf wire format -----------------------------------------------------------------------------
VARINT, I64, LEN, I32 = 0, 1, 2, 5
# FieldDescriptorProto.Type numbers
DOUBLE, FLOAT, INT64, UINT64, INT32, FIXED64, FIXED32, BOOL, STRING, GROUP, MESSAGE, BYTES, UINT32, ENUM, \
    SFIXED32, SFIXED64, SINT32, SINT64 = range(1, 19)
REPEATED = 3
_PACKABLE = {DOUBLE, FLOAT, INT64, UINT64, INT32, FIXED64, FIXED32, BOOL, UINT32, ENUM, SFIXED32, SFIXED64, SINT32,
             SINT64}
_DEFAULTS: dict[int, Any] = {DOUBLE: 0.0, FLOAT: 0.0, BOOL: False, STRING: "", BYTES: b""}


def _varint(data: bytes, at: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = data[at]
        at += 1
        value |= (byte & 0x7F) << shift
        if byte < 0x80:
            return value, at
        shift += 7


def wire_fields(data: bytes) -> Iterable[tuple[int, int, Any]]:
    """(field number, wire type, raw value) of each field of one encoded message, in order."""
    at = 0
    while at < len(data):
        key, at = _varint(data, at)
        number, wire = key >> 3, key & 7
        if wire == VARINT:
            value, at = _varint(data, at)
        elif wire == I64:
            value, at = data[at:at + 8], at + 8
        elif wire == I32:
            value, at = data[at:at + 4], at + 4
        elif wire == LEN:
            size, at = _varint(data, at)
            value, at = data[at:at + size], at + size
        else:
            raise ValueError(f"wire type {wire} not supported")
        yield number, wire, value


def _signed(value: int, bits: int) -> int:
    return value - (1 << bits) if value >= 1 << (bits - 1) else value


def _scalar(kind: int, wire: int, raw: Any) -> Any:
    if kind == DOUBLE:
        return struct.unpack("<d", raw)[0]
    if kind == FLOAT:
        return struct.unpack("<f", raw)[0]
    if kind in (FIXED64, SFIXED64):
        return struct.unpack("<Q" if kind == FIXED64 else "<q", raw)[0]
    if kind in (FIXED32, SFIXED32):
        return struct.unpack("<I" if kind == FIXED32 else "<i", raw)[0]
    if kind in (SINT32, SINT64):
        return (raw >> 1) ^ -(raw & 1)
    if kind in (INT32, INT64):
        return _signed(raw, 64)
    if kind == BOOL:
        return bool(raw)
    return raw  # uint32, uint64, enum


def _packed(kind: int, data: bytes) -> list[Any]:
    if kind in (DOUBLE, FIXED64, SFIXED64):
        return [_scalar(kind, I64, data[i:i + 8]) for i in range(0, len(data), 8)]
    if kind in (FLOAT, FIXED32, SFIXED32):
        return [_scalar(kind, I32, data[i:i + 4]) for i in range(0, len(data), 4)]
    values, at = [], 0
    while at < len(data):
        raw, at = _varint(data, at)
        values.append(_scalar(kind, VARINT, raw))
    return values


@dataclass
class FieldSpec:
    name: str
    number: int
    kind: int
    repeated: bool
    type_name: str  # ".package.Message" for messages and enums


@dataclass
class Schemas:
    """The message types of one advertised ``FileDescriptorSet``, by full name ("foxglove.RawImage")."""

    messages: dict[str, dict[int, FieldSpec]] = field(default_factory=dict)

    @classmethod
    def from_descriptor_set(cls, data: bytes) -> Schemas:
        schemas = cls()
        for number, _, file_bytes in wire_fields(data):
            if number == 1:  # FileDescriptorSet.file
                schemas._add_file(file_bytes)
        return schemas

    def _add_file(self, data: bytes) -> None:
        package = ""
        types = []
        for number, _, value in wire_fields(data):
            if number == 2:
                package = value.decode()
            elif number == 4:  # message_type
                types.append(value)
        for message in types:
            self._add_message(package, message)

    def _add_message(self, scope: str, data: bytes) -> None:
        name, fields, nested = "", {}, []
        for number, _, value in wire_fields(data):
            if number == 1:
                name = value.decode()
            elif number == 2:
                spec = self._field(value)
                fields[spec.number] = spec
            elif number == 3:
                nested.append(value)
        full = f"{scope}.{name}" if scope else name
        self.messages[full] = fields
        for message in nested:
            self._add_message(full, message)

    @staticmethod
    def _field(data: bytes) -> FieldSpec:
        spec = FieldSpec("", 0, 0, False, "")
        for number, _, value in wire_fields(data):
            if number == 1:
                spec.name = value.decode()
            elif number == 3:
                spec.number = value
            elif number == 4:
                spec.repeated = value == REPEATED
            elif number == 5:
                spec.kind = value
            elif number == 6:
                spec.type_name = value.decode().lstrip(".")
        return spec

    def decode(self, type_name: str, data: bytes) -> dict[str, Any]:
        """A message as a dict of field name to value (lists for repeated fields, dicts for messages); a scalar
        not on the wire has its default (proto3 leaves defaults out), a message not on the wire is left out."""
        specs = self.messages[type_name]
        out: dict[str, Any] = {}
        for number, wire, raw in wire_fields(data):
            spec = specs.get(number)
            if spec is None:
                continue
            if spec.kind == MESSAGE:
                value: Any = self.decode(spec.type_name, raw)
            elif spec.kind == STRING:
                value = raw.decode()
            elif spec.kind == BYTES:
                value = bytes(raw)
            elif wire == LEN and spec.kind in _PACKABLE:
                out.setdefault(spec.name, []).extend(_packed(spec.kind, raw))
                continue
            else:
                value = _scalar(spec.kind, wire, raw)
            if spec.repeated:
                out.setdefault(spec.name, []).append(value)
            else:
                out[spec.name] = value
        for spec in specs.values():
            if spec.name not in out and (spec.repeated or spec.kind != MESSAGE):
                out[spec.name] = [] if spec.repeated else _DEFAULTS.get(spec.kind, 0)
        return out


# -- the client -------------------------------------------------------------------------------------------
@dataclass
class Channel:
    id: int
    topic: str
    encoding: str
    schema_name: str
    schemas: Schemas | None  # protobuf channels


@dataclass
class Received:
    topic: str
    log_time: int
    message: Any  # dict (decoded protobuf or JSON)


class FoxgloveClient:
    """Connects, learns the channels, subscribes to topics and decodes what arrives, on a thread of its own
    (so that a test can run the command in the foreground).

    ``read=False`` subscribes and then never reads a byte: a stalled viewer.
    """

    def __init__(self, url: str, topics: Iterable[str] | Callable[[str], bool], *, read: bool = True,
                 keep: int = 10_000, deadline: float = 120.0) -> None:
        self.url = url
        self.wants = topics if callable(topics) else set(topics).__contains__
        self.read = read
        self.keep = keep
        self.deadline = deadline
        self.channels: dict[int, Channel] = {}
        self.subscriptions: dict[int, Channel] = {}
        self.received: list[Received] = []
        self.server_info: dict[str, Any] = {}
        self.subprotocol: str | None = None
        self.subscribed = threading.Event()
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name="foxglove-test-client", daemon=True)

    def __enter__(self) -> FoxgloveClient:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=30)

    def messages(self, topic: str) -> list[Received]:
        with self._lock:
            return [r for r in self.received if r.topic == topic]

    def wait_for(self, condition: Callable[[FoxgloveClient], bool], timeout: float = 60.0) -> bool:
        """Poll ``condition`` until true or a generous hang guard; never a timing assertion."""
        end = threading.Event()
        for _ in range(int(timeout / 0.05)):
            if condition(self) or self.error is not None:
                return condition(self)
            end.wait(0.05)
        return condition(self)

    def _run(self) -> None:
        try:
            asyncio.run(asyncio.wait_for(self._session(), self.deadline))
        except TimeoutError:
            pass
        except BaseException as exc:  # reported to the test through .error
            if not self._stop.is_set():
                self.error = exc

    async def _session(self) -> None:
        async with websockets.connect(self.url, subprotocols=SUBPROTOCOLS, max_size=None,  # type: ignore[arg-type]
                                      open_timeout=30, proxy=None) as ws:
            self.subprotocol = ws.subprotocol
            while not self._stop.is_set():
                if not self.read and self.subscribed.is_set():
                    await asyncio.sleep(0.05)  # a stalled viewer: the connection stays open, nothing is read
                    continue
                try:
                    frame = await asyncio.wait_for(ws.recv(), 0.2)
                except TimeoutError:
                    continue
                except websockets.ConnectionClosed:
                    return
                if isinstance(frame, str):
                    await self._control(ws, json.loads(frame))
                else:
                    self._data(frame)

    async def _control(self, ws: Any, message: dict[str, Any]) -> None:
        op = message.get("op")
        if op == "serverInfo":
            self.server_info = message
        elif op == "advertise":
            new = []
            for c in message["channels"]:
                schemas = None
                if c.get("schemaEncoding") == "protobuf":
                    schemas = Schemas.from_descriptor_set(base64.b64decode(c["schema"]))
                channel = Channel(c["id"], c["topic"], c["encoding"], c.get("schemaName", ""), schemas)
                self.channels[channel.id] = channel
                if self.wants(channel.topic):
                    new.append(channel)
            if new:
                subscriptions = []
                for channel in new:
                    sub_id = len(self.subscriptions) + 1
                    self.subscriptions[sub_id] = channel
                    subscriptions.append({"id": sub_id, "channelId": channel.id})
                await ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
                self.subscribed.set()

    def _data(self, frame: bytes) -> None:
        if frame[0] != MESSAGE_DATA:
            return
        sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
        payload = frame[13:]
        channel = self.subscriptions[sub_id]
        if channel.encoding == "json":
            message: Any = json.loads(payload)
        elif channel.schemas is not None:
            message = channel.schemas.decode(channel.schema_name, payload)
        else:
            message = payload
        with self._lock:
            self.received.append(Received(channel.topic, log_time, message))
            del self.received[:-self.keep]
