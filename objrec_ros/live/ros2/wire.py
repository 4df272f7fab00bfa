"""Serialized samples in and out of cyclonedds, with no Python-object round trip.

cyclonedds' own ``DataReader.take`` and ``DataWriter.write`` move serialized bytes through its C layer
(``ddspy_take``, ``ddspy_write``) and turn them into Python objects field by field (a 640 x 480 image is
921,600 Python ints). The transport only moves bytes, and those bytes are already what rosbags writes
(XCDR1 with its 4-byte encapsulation header), so this module calls the same two C-layer functions and
skips the objects. It is the one place that knows that layer: cyclonedds 0.10 to 11 have it unchanged.

Padding: a DDS payload is a whole number of 4-byte words. XTypes (7.6.3.1.2) says the last two bits of the
encapsulation options count the padding bytes added; objrec's writer sets them, and its reader strips the
padding they announce (and clears those bits), so bytes published from rosbags arrive as the same bytes.
A writer that pads without saying so (cyclonedds' Python writer) leaves at most 3 zero bytes, which
rosbags' deserializer accepts.
"""

from __future__ import annotations

from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import DDSException, InstanceState, SampleState, ViewState
from cyclonedds.idl import IdlStruct
from cyclonedds.idl._support import Endianness
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from ..transport import LiveError

_ANY = SampleState.Any | ViewState.Any | InstanceState.Any
#: Encapsulation identifiers of plain CDR (XCDR1), big and little endian: passed on as they are.
_XCDR1 = (b"\x00\x00", b"\x00\x01")
_MAX_TAKE = 64


def take_raw(reader: DataReader, data_type: type[IdlStruct]) -> list[bytes]:
    """Every valid sample waiting in ``reader``, oldest first, as XCDR1 bytes without padding."""
    taken = ddspy_take(reader._ref, _ANY, _MAX_TAKE)
    if isinstance(taken, int):
        raise DDSException(taken, f"taking samples from {reader!r}")
    return [_as_xcdr1(bytes(data), data_type) for data, info in taken if info.valid_data]


def _as_xcdr1(data: bytes, data_type: type[IdlStruct]) -> bytes:
    if len(data) < 4:
        return data
    if data[:2] not in _XCDR1:
        # An XCDR2 writer (possible with some DDS vendors' settings): re-encode as rosbags reads.
        sample = data_type.deserialize(data)
        return sample.serialize(use_version_2=False, endianness=Endianness.Little)
    padding = data[3] & 3
    if not padding:
        return data
    # Without its padding the payload is as rosbags wrote it: options back to what they were.
    return data[:3] + bytes([data[3] & ~3]) + data[4:len(data) - padding]


def write_raw(writer: DataWriter, raw: bytes) -> None:
    """Write XCDR1 bytes (rosbags' ``serialize_cdr``) as one sample, padded to 4 bytes as XTypes says.

    LiveError when the bytes are not CDR; a reliable writer's timeout (readers lagging past the QoS's
    max blocking time) is DDSException with DDS_RETCODE_TIMEOUT, which the caller counts as dropped.
    """
    if len(raw) < 4 or bytes(raw[:2]) not in _XCDR1:
        raise LiveError(f"ros2: {writer.topic.name}: the message is not CDR (starts {bytes(raw[:4]).hex()})")
    padding = -len(raw) % 4
    if padding:
        raw = bytes(raw[:3]) + bytes([(raw[3] & ~3) | padding]) + bytes(raw[4:]) + b"\0" * padding
    ret = ddspy_write(writer._ref, bytes(raw))
    if ret < 0:
        raise DDSException(ret, f"writing on {writer.topic.name}")
