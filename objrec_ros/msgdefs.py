"""Typed ROS messages from plain dicts, with nothing known about the message but its definition.

An array class of detections carries ``ros_type`` (its ROS type name) and ``ros_definitions`` (ROS ``.msg``
text for each of its own types); the standard types they build on (``std_msgs/Header``,
``geometry_msgs/Polygon``, ...) come from rosbags' typestores. ``message_from_dict`` walks the typestore's
field definitions, so a kind that brings its own array class and definitions is written the same way.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.base import normalize_fieldname
from rosbags.typesys.store import Typestore

#: The standard types each ROS version's messages are built on (ROS 2: the newest distribution rosbags knows).
STANDARD_STORES = {1: Stores.ROS1_NOETIC, 2: Stores.LATEST}

_TIME = "builtin_interfaces/msg/Time"
_DURATION = "builtin_interfaces/msg/Duration"
#: Fields a dict may carry that one ROS version's type lacks: a ROS 2 header has no sequence number.
_DROPPED = {"std_msgs/msg/Header": frozenset({"seq"})}
#: The dicts' ROS 1 names for the time fields, as ``Header.to_dict`` writes them.
_ALIASES = {"sec": "secs", "nanosec": "nsecs"}
_DTYPES = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
}


class MessageDefinitionError(ValueError):
    """An array class's ROS definitions that cannot be used (a programming error in the kind, not the user's)."""


def standard_typestore(ros_version: int) -> Typestore:
    """A fresh typestore with the standard message types of ROS 1 (Noetic) or ROS 2."""
    return get_typestore(STANDARD_STORES[ros_version])


def register_definitions(typestore: Typestore, ros_type: str, definitions: Mapping[str, str]) -> None:
    """Add an array class's own types to ``typestore``; every type they use must then be known."""
    if ros_type not in definitions:
        raise MessageDefinitionError(f"{ros_type}: not among the definitions given ({', '.join(definitions)})")
    types: dict[str, Any] = {}
    for name, text in definitions.items():
        try:
            types.update(get_types_from_msg(text, name))
        except Exception as exc:  # rosbags' parser raises its own error types
            raise MessageDefinitionError(f"{name}: the message definition cannot be parsed: {exc}") from None
    try:
        typestore.register(types)
    except Exception as exc:
        raise MessageDefinitionError(f"{ros_type}: {exc}") from None
    _check_known(typestore, ros_type, set())


def _check_known(typestore: Typestore, typename: str, seen: set[str]) -> None:
    if typename in seen:
        return
    seen.add(typename)
    if typename not in typestore.fielddefs:
        raise MessageDefinitionError(f"{typename}: used in a definition but neither defined nor a standard type")
    for _, desc in typestore.fielddefs[typename][1]:
        inner = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
        if inner[0] == Nodetype.NAME:
            _check_known(typestore, inner[1], seen)


def message_from_dict(typestore: Typestore, typename: str, data: Any, where: str = "") -> Any:
    """The typed message of ``typename`` with the values of ``data`` (a ``to_dict()`` result), field by field.

    Missing fields get ROS's defaults (0, "", empty); a field the type does not have is an error, except the
    ones one ROS version leaves out (a ROS 2 header's ``seq``). ``where`` names the field for messages.
    """
    where = where or typename
    if typename in (_TIME, _DURATION) and isinstance(data, int | float):
        data = _time_dict(data)
    if not isinstance(data, Mapping):
        raise MessageDefinitionError(f"{where}: expected a mapping for {typename}, got {type(data).__name__}")
    fields = typestore.fielddefs[typename][1]
    names = {name for name, _ in fields}
    aliases = {_ALIASES[n]: n for n in names if n in _ALIASES}
    unknown = set(data) - names - set(aliases) - _DROPPED.get(typename, frozenset())
    if unknown:
        raise MessageDefinitionError(f"{where}: {typename} has no field {', '.join(sorted(unknown))}")
    values: dict[str, Any] = {}
    for name, desc in fields:
        if name == "structure_needs_at_least_one_member":
            values[name] = 0
            continue
        key = name if name in data else _ALIASES.get(name, name)
        values[normalize_fieldname(name)] = _value(typestore, desc, data.get(key), f"{where}.{name}")
    return typestore.types[typename](**values)


def _time_dict(seconds: float) -> dict[str, int]:
    whole = int(np.floor(seconds))
    return {"sec": whole, "nanosec": min(round((seconds - whole) * 1e9), 999_999_999)}


def _value(typestore: Typestore, desc: Any, raw: Any, where: str) -> Any:
    kind, detail = desc
    if kind == Nodetype.BASE:
        return _base(detail[0], raw, where)
    if kind == Nodetype.NAME:
        return message_from_dict(typestore, detail, {} if raw is None else raw, where)
    (inner_kind, inner), size = detail
    items = list(raw) if raw is not None else []
    if kind == Nodetype.ARRAY and raw is None:
        items = [None] * size
    if kind == Nodetype.ARRAY and len(items) != size:
        raise MessageDefinitionError(f"{where}: expected {size} values, got {len(items)}")
    if kind == Nodetype.SEQUENCE and size and len(items) > size:
        raise MessageDefinitionError(f"{where}: at most {size} values, got {len(items)}")
    if inner_kind == Nodetype.NAME:
        return [message_from_dict(typestore, inner, {} if v is None else v, f"{where}[{i}]")
                for i, v in enumerate(items)]
    if inner[0] == "string":
        return [_base("string", v, f"{where}[{i}]") for i, v in enumerate(items)]
    return np.array([_base(inner[0], v, f"{where}[{i}]") for i, v in enumerate(items)], dtype=_DTYPES[inner[0]])


def _base(name: str, raw: Any, where: str) -> Any:
    if name in ("string", "wstring"):
        if raw is None:
            return ""
        if not isinstance(raw, str):
            raise MessageDefinitionError(f"{where}: expected text, got {raw!r}")
        return raw
    if raw is None:
        return False if name == "bool" else 0.0 if name.startswith("float") else 0
    if name == "bool":
        return bool(raw)
    if name.startswith("float"):
        return float(raw)
    if isinstance(raw, float) and not raw.is_integer():
        raise MessageDefinitionError(f"{where}: expected an integer ({name}), got {raw!r}")
    return int(raw)
