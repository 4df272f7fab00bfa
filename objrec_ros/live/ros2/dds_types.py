"""DDS types built at run time from a rosbags typestore, as ROS 2's generated IDL spells them.

A DDS reader or writer needs a type: its name (``sensor_msgs::msg::dds_::Image_``) is what peers match
on, and its layout is what cyclonedds announces (XTypes type information) and uses to (de)serialize. The
type is made here from the typestore's field definitions, nested types included, so any message rosbags
knows (the standard ones and a kind's own detection arrays) can be published or subscribed with no
generated code. The layout follows ROS 2's ``.msg`` to IDL mapping (``uint8[] data`` -> ``sequence<uint8>``,
``float64[9] k`` -> ``double k[9]``, ``string<=10`` -> ``string<10>``, ``byte`` -> ``octet``, ``char`` ->
``uint8``), so the XCDR1 bytes of a sample are those of rosbags' ``serialize_cdr`` (proved in the tests).
"""

from __future__ import annotations

import keyword
import threading
import weakref
from typing import Any

from cyclonedds.idl import IdlStruct, make_idl_struct
from cyclonedds.idl import types as t
from rosbags.interfaces import Nodetype
from rosbags.typesys.store import Typestore

from ..transport import LiveError
from .naming import dds_type

_BASE: dict[str, Any] = {
    "bool": bool, "byte": t.byte, "char": t.uint8, "int8": t.int8, "uint8": t.uint8,
    "int16": t.int16, "uint16": t.uint16, "int32": t.int32, "uint32": t.uint32,
    "int64": t.int64, "uint64": t.uint64, "float32": t.float32, "float64": t.float64,
}

_cache: weakref.WeakKeyDictionary[Typestore, dict[str, type[IdlStruct]]] = weakref.WeakKeyDictionary()
_lock = threading.Lock()


def idl_struct(typestore: Typestore, msgtype: str) -> type[IdlStruct]:
    """The cyclonedds type of ``msgtype`` (rosbags' form), made once per typestore and type.

    LiveError naming the type when the typestore does not know it or it holds what DDS cannot carry here
    (wide strings).
    """
    with _lock:
        built = _cache.setdefault(typestore, {})
        return _struct(typestore, msgtype, built)


def _struct(typestore: Typestore, msgtype: str, built: dict[str, type[IdlStruct]]) -> type[IdlStruct]:
    if msgtype in built:
        return built[msgtype]
    if msgtype not in typestore.fielddefs:
        raise LiveError(f"ros2: type {msgtype} is not known (not a standard ROS 2 type, nor one of objrec's)")
    fields: dict[str, Any] = {}
    for name, desc in typestore.fielddefs[msgtype][1]:
        field = name + "_" if keyword.iskeyword(name) else name
        fields[field] = _field_type(typestore, desc, built, f"{msgtype}.{name}")
    cls = make_idl_struct(msgtype.replace("/", "_"), dds_type(msgtype), fields)
    built[msgtype] = cls
    return cls


def _field_type(typestore: Typestore, desc: Any, built: dict[str, type[IdlStruct]], where: str) -> Any:
    kind, detail = desc
    if kind == Nodetype.BASE:
        return _base(detail, where)
    if kind == Nodetype.NAME:
        return _struct(typestore, detail, built)
    inner_desc, size = detail
    inner = _field_type(typestore, inner_desc, built, where)
    if kind == Nodetype.ARRAY:
        return t.array[inner, size]
    return t.sequence[inner, size] if size else t.sequence[inner]


def _base(detail: tuple[str, int], where: str) -> Any:
    name, bound = detail
    if name == "string":
        return t.bounded_str[bound] if bound else str
    if name in _BASE:
        return _BASE[name]
    raise LiveError(f"ros2: {where}: the type {name} cannot be carried over DDS here")
