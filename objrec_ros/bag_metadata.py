"""A ROS 2 bag's ``metadata.yaml`` checked field by field before rosbags reads it.

rosbags takes ``message_count: lots`` or a ``duration`` without nanoseconds as it comes and fails later with a
TypeError deep inside (a traceback, or a message that names no field). Here every field rosbags uses is checked
for its type and range first, so a careless or hostile file is one line naming the field and its value.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from strictio.shown import printable

#: What rosbags reads of ``rosbag2_bagfile_information`` and the type each must have.
_INTEGERS = ("version", "message_count")
_TEXTS = ("storage_identifier",)
_OPTIONAL_TEXTS = ("compression_format", "compression_mode", "ros_distro")
#: Versions of the metadata format rosbags reads.
MAX_VERSION = 9
_BIGGEST = 2**63 - 1


class MetadataError(ValueError):
    """A field of metadata.yaml that is missing or holds the wrong kind of value: ``field`` names it."""

    def __init__(self, field: str, value: Any, why: str) -> None:
        self.field = field
        shown = "missing" if value is _MISSING else f"{printable(repr(value), 60)}"
        super().__init__(f"metadata.yaml: {field}: {shown}: {why}")


_MISSING = object()


def _get(mapping: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in mapping:
        raise MetadataError(f"{where}{key}", _MISSING, "required")
    return mapping[key]


def _integer(value: Any, field: str, *, low: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise MetadataError(field, value, "not a whole number")
    if not low <= value <= _BIGGEST:
        raise MetadataError(field, value, f"out of range ({low}..{_BIGGEST})")
    return value


def _text(value: Any, field: str) -> str:
    if not isinstance(value, str):
        raise MetadataError(field, value, "not text")
    return value


def _mapping(value: Any, field: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise MetadataError(field, value, "not a mapping")
    return value


def _list(value: Any, field: str) -> list[Any]:
    if not isinstance(value, list):
        raise MetadataError(field, value, "not a list")
    return value


def check_metadata(info: Mapping[str, Any]) -> None:
    """Raise MetadataError for the first field of ``rosbag2_bagfile_information`` rosbags could not use."""
    top = "rosbag2_bagfile_information."
    version = _integer(_get(info, "version", top), top + "version", low=1)
    if version > MAX_VERSION:
        raise MetadataError(top + "version", version, f"newer than the versions read (1..{MAX_VERSION})")
    for key in _INTEGERS[1:]:
        _integer(_get(info, key, top), top + key)
    for key in _TEXTS:
        _text(_get(info, key, top), top + key)
    for key in _OPTIONAL_TEXTS:
        if info.get(key) is not None:
            _text(info[key], top + key)
    for index, name in enumerate(_list(_get(info, "relative_file_paths", top), top + "relative_file_paths")):
        _text(name, f"{top}relative_file_paths[{index}]")
    duration = _mapping(_get(info, "duration", top), top + "duration")
    _integer(_get(duration, "nanoseconds", top + "duration."), top + "duration.nanoseconds")
    start = _mapping(_get(info, "starting_time", top), top + "starting_time")
    _integer(_get(start, "nanoseconds_since_epoch", top + "starting_time."),
             top + "starting_time.nanoseconds_since_epoch")
    topics = _list(_get(info, "topics_with_message_count", top), top + "topics_with_message_count")
    for index, entry in enumerate(topics):
        where = f"{top}topics_with_message_count[{index}]"
        entry = _mapping(entry, where)
        _integer(_get(entry, "message_count", where + "."), where + ".message_count")
        meta = _mapping(_get(entry, "topic_metadata", where + "."), where + ".topic_metadata")
        for key in ("name", "type", "serialization_format"):
            _text(_get(meta, key, where + ".topic_metadata."), f"{where}.topic_metadata.{key}")
        qos = meta.get("offered_qos_profiles")
        if qos is not None and not isinstance(qos, str | list):
            raise MetadataError(f"{where}.topic_metadata.offered_qos_profiles", qos, "not text or a list")
        digest = meta.get("type_description_hash")
        if digest is not None:
            _text(digest, f"{where}.topic_metadata.type_description_hash")
    files = info.get("files")
    for index, entry in enumerate(_list(files, top + "files") if files is not None else []):
        where = f"{top}files[{index}]"
        entry = _mapping(entry, where)
        if "path" in entry:
            _text(entry["path"], where + ".path")
        if "message_count" in entry:
            _integer(entry["message_count"], where + ".message_count")


def compression_mode(info: Mapping[str, Any]) -> str:
    """``file``, ``message`` or "" (none) from checked metadata."""
    mode = str(info.get("compression_mode") or "").lower()
    return "" if mode == "none" else mode
