"""Embedded message definitions checked against the standard ones before objrec decodes a standard type.

A recording carries its own definitions and rosbags decodes with them, which is right for a type objrec does not
know; but a recording that defines ``sensor_msgs/Image`` with ``string height`` or ``PointCloud2`` with a string
``fields`` decodes "fine" into messages the decoders cannot read (a traceback deep in NumPy). The decoders read
the standard layout, so a standard type they read must be laid out as standard: the first field that differs is
named, with what the recording declares and what the standard type has.
"""

from __future__ import annotations

from typing import Any

#: The standard types objrec's decoders read (``objrec_ros.decode``), with std_msgs/Header inside them.
DECODED_TYPES = frozenset({
    "sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage", "sensor_msgs/msg/PointCloud2",
    "sensor_msgs/msg/CameraInfo",
})


def describe(desc: Any) -> str:
    """A field's type as a .msg file writes it (``uint32``, ``string``, ``PointField[]``, ``float64[9]``)."""
    from rosbags.interfaces import Nodetype  # with a recording, not with this module (see objrec_ros.bags)

    kind, detail = desc
    if kind == Nodetype.BASE:
        return str(detail[0])
    if kind == Nodetype.NAME:
        return str(detail).replace("/msg/", "/")
    (inner, size) = detail
    return f"{describe(inner)}[{size if kind == Nodetype.ARRAY else ''}]"


def first_difference(recorded: Any, standard: Any, msgtype: str, prefix: str = "",
                     seen: set[str] | None = None) -> str | None:
    """Where ``msgtype`` in the recording's typestore differs from the standard typestore: ``field: declared
    X, standard Y`` for the first differing field (nested types followed), or None when they agree."""
    from rosbags.interfaces import Nodetype

    seen = set() if seen is None else seen
    if msgtype in seen:
        return None
    seen.add(msgtype)
    if msgtype not in recorded.fielddefs or msgtype not in standard.fielddefs:
        return None
    have, want = recorded.fielddefs[msgtype][1], standard.fielddefs[msgtype][1]
    for index in range(max(len(have), len(want))):
        if index >= len(have):
            return f"{prefix}{want[index][0]}: missing (standard: {describe(want[index][1])})"
        name, desc = have[index]
        if index >= len(want):
            return f"{prefix}{name}: declared {describe(desc)}, not in the standard type"
        wanted_name, wanted = want[index]
        if name != wanted_name:
            return f"{prefix}{name}: declared where the standard type has {wanted_name} ({describe(wanted)})"
        if describe(desc) != describe(wanted):
            return f"{prefix}{name}: declared {describe(desc)}, standard {describe(wanted)}"
        inner = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
        if inner[0] == Nodetype.NAME:
            found = first_difference(recorded, standard, inner[1], f"{prefix}{name}.", seen)
            if found:
                return found
    return None
