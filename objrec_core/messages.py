"""Message types shared by 2D and 3D: the ROS ``std_msgs/Header`` and the detected-object array.

The concrete object types (``DetectedObject2D``, ``DetectedObject3D``) live in their packages; they are
dataclasses whose fields follow the ROS messages ``object_detection_2d_msgs``/``object_detection_3d_msgs``,
so ``to_dict`` gives the same nesting a ROS
consumer would see, one JSON object per line.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar


@dataclass(frozen=True, slots=True)
class Header:
    """``std_msgs/Header``: sequence number, time stamp (seconds since the epoch) and frame id.

    ``stamp_ns``, where the source knows it (a ROS message's own stamp), is the exact time: a float of seconds
    since 1970 keeps only about a quarter of a microsecond, and a detection must carry its image's stamp to
    the nanosecond for a ROS consumer to pair them.
    """

    seq: int = 0
    stamp: float = 0.0
    frame_id: str = ""
    stamp_ns: int | None = field(default=None, compare=False)  # a refinement of stamp, not another time

    @classmethod
    def fast(cls, seq: int, stamp: float, frame_id: str, stamp_ns: int | None) -> Header:
        """The same header as ``Header(seq, stamp, frame_id, stamp_ns)`` in a third of the time: a frozen
        dataclass's ``__init__`` sets each field through ``object.__setattr__``, and a director makes one per
        frame. Filled as an unfrozen twin of the same slots, then made a ``Header``."""
        if cls is not Header:  # a subclass may have another layout
            return cls(seq, stamp, frame_id, stamp_ns)
        header = _UnfrozenHeader()
        header.seq = seq
        header.stamp = stamp
        header.frame_id = frame_id
        header.stamp_ns = stamp_ns
        header.__class__ = cls
        return header

    def to_dict(self) -> dict[str, Any]:
        if self.stamp_ns is not None:
            secs, nsecs = divmod(self.stamp_ns, 1_000_000_000)
        else:
            secs = math.floor(self.stamp)
            nsecs = min(round((self.stamp - secs) * 1e9), 999_999_999)
        return {"seq": self.seq, "stamp": {"secs": secs, "nsecs": nsecs}, "frame_id": self.frame_id}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Header:
        stamp = data.get("stamp", 0.0)
        stamp_ns = None
        if isinstance(stamp, dict):
            stamp_ns = int(stamp.get("secs", 0)) * 1_000_000_000 + int(stamp.get("nsecs", 0))
            stamp = stamp_ns / 1e9
        return cls(seq=int(data.get("seq", 0)), stamp=float(stamp), frame_id=str(data.get("frame_id", "")),
                   stamp_ns=stamp_ns)


class _UnfrozenHeader:
    """``Header``'s slots without its frozen guard (``Header.fast``; the layouts are the same, so Python lets
    one become the other through ``__class__``)."""

    __slots__ = Header.__slots__


def message_to_dict(message: Any) -> Any:
    """Dataclass messages to plain dicts/lists (``dataclasses.asdict`` with our Header rule)."""
    if hasattr(message, "to_dict"):
        return message.to_dict()
    if dataclasses.is_dataclass(message):
        return {f.name: message_to_dict(getattr(message, f.name)) for f in dataclasses.fields(message)}
    if isinstance(message, list | tuple):
        return [message_to_dict(m) for m in message]
    return message


@dataclass
class DetectedObjectArray:
    """All objects found in one frame, under one header.

    Subclasses set ``object_type`` so that ``from_dict`` can rebuild typed objects from a JSON line.
    """

    header: Header = field(default_factory=Header)
    objects: list[Any] = field(default_factory=list)

    object_type: ClassVar[Any] = None

    def __len__(self) -> int:
        return len(self.objects)

    def to_dict(self) -> dict[str, Any]:
        return {"header": self.header.to_dict(), "objects": [message_to_dict(o) for o in self.objects]}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), separators=(",", ":"))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DetectedObjectArray:
        make = getattr(cls.object_type, "from_dict", None)
        objects = [make(o) if make else o for o in data.get("objects", [])]
        return cls(header=Header.from_dict(data.get("header", {})), objects=objects)

    @classmethod
    def from_json(cls, line: str) -> DetectedObjectArray:
        return cls.from_dict(json.loads(line))
