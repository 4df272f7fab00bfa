"""Detections saved earlier, read back for objrec-eval: JSON Lines (objrec-detect's default output) and typed
ROS messages in an MCAP file, a ROS 1 bag or a ROS 2 bag folder (objrec-detect ``--output``).

JSON Lines do not say their kind (``--kind`` does, or the truth file); a typed recording does: its message type
is some registered kind's ``object_array_type.ros_type``. A typed message is turned back into the JSON line's
form (``DetectedObjectArray.from_dict``): the stamp's ROS field names (``sec``/``nanosec``) become the JSON
line's (``secs``/``nsecs``), so a saved file is scored exactly as the run that wrote it.
"""

from __future__ import annotations

import dataclasses
import json
import logging
from collections.abc import Iterator
from itertools import pairwise
from pathlib import Path
from typing import Any

from objrec_core import DetectedObjectArray, Header, Kind, SourceError, get_kind, kind_names
from objrec_ros.bags import RECORDING_SUFFIXES
from strictio import InputError, open_input

from .cli import UserError

log = logging.getLogger("objrec.eval")
#: The longest JSON line read (a frame with thousands of polygon points is well under it).
LINE_LIMIT = 64 * 1024 * 1024


def is_recording(path: str) -> bool:
    """Whether ``path`` names typed detections (an MCAP file, a ROS 1 bag or a ROS 2 bag folder)."""
    return Path(path).is_dir() or Path(path).suffix.lower() in RECORDING_SUFFIXES


def read_json_lines(path: str, kind: Kind) -> Iterator[DetectedObjectArray]:
    """Every line of a JSON Lines file as the kind's detection array; a line that is not one is an InputError
    naming the file and the line."""
    with open_input(path, limit=None) as stream:
        for number, raw in enumerate(stream, start=1):
            if len(raw) > LINE_LIMIT:
                raise InputError(path, f"longer than {LINE_LIMIT:,} bytes", f"line {number}")
            text = raw.decode("utf-8", errors="replace").strip()
            if not text:
                continue
            try:
                data = json.loads(text)
                if not isinstance(data, dict):
                    raise ValueError(f"a JSON {type(data).__name__}, not an object with header and objects")
                yield kind.object_array_type.from_dict(data)
            except (ValueError, TypeError, KeyError, AttributeError) as exc:
                message = " ".join(str(exc).split()) or type(exc).__name__
                raise InputError(path, f"not a detections line of the {kind.name} kind: {message}",
                                 f"line {number}") from None


def with_skipped_frames(arrays: list[DetectedObjectArray], path: str) -> list[DetectedObjectArray]:
    """The arrays with an empty one put back for each frame ``objrec-detect --skip-empty`` left out, so that the
    n-th array is frame n again. The frames are counted by the header's ``seq`` (the run's frame count), where
    it counts up without repeating; a typed ROS 2 output has no ``seq`` (all 0) and is left as it is. Frames
    left out after the last line cannot be known: a warning says so."""
    seqs = [a.header.seq for a in arrays]
    if not arrays or seqs[0] < 0 or any(b <= a for a, b in pairwise(seqs)):
        return arrays
    if seqs == list(range(len(arrays))):
        return arrays
    filled: list[DetectedObjectArray] = []
    for array in arrays:
        while len(filled) < array.header.seq:
            filled.append(type(array)(header=Header(seq=len(filled)), objects=[]))
        filled.append(array)
    log.warning("%s: %d frames without detections were left out of it (--skip-empty): scored as empty; frames "
                "left out after its last line are not scored", path, len(filled) - len(arrays))
    return filled


def _plain(value: Any) -> Any:
    """A decoded rosbags message as plain dicts and lists, with the JSON line's stamp names."""
    if dataclasses.is_dataclass(value):
        fields = {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value) if f.name != "__msgtype__"}
        if set(fields) == {"sec", "nanosec"}:
            return {"secs": fields["sec"], "nsecs": fields["nanosec"]}
        return fields
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def kinds_by_ros_type() -> dict[str, Kind]:
    """Each registered kind that has a typed message, by the message's ROS type name."""
    found = {}
    for name in kind_names():
        kind = get_kind(name)
        ros_type = getattr(kind.object_array_type, "ros_type", None)
        if ros_type:
            found[ros_type] = kind
    return found


def detection_topic(path: str, topic: str | None) -> tuple[str, Kind]:
    """The topic of typed detections in a recording and its kind: ``topic`` if given, else the only one of a
    detection type; a UserError naming the file otherwise."""
    from objrec_ros.bags import open_recording

    known = kinds_by_ros_type()
    try:
        with open_recording(path) as recording:
            topics = recording.topics()
    except SourceError as exc:
        raise UserError(str(exc)) from None
    detections = [t for t in topics if t.msgtype in known]
    if topic is not None:
        chosen = [t for t in topics if t.name == topic]
        if not chosen:
            raise UserError(f"{path}: no topic {topic} (topics: {', '.join(t.name for t in topics) or 'none'})")
        if chosen[0].msgtype not in known:
            raise UserError(f"{path}: topic {topic} holds {chosen[0].msgtype}, not detections "
                            f"({', '.join(sorted(known))})")
        return topic, known[chosen[0].msgtype]
    if not detections:
        raise UserError(f"{path}: no topic of detections ({', '.join(sorted(known))}); topics: "
                        f"{', '.join(f'{t.name} ({t.msgtype})' for t in topics) or 'none'}")
    if len(detections) > 1:
        raise UserError(f"{path}: several topics of detections ({', '.join(t.name for t in detections)}): "
                        "give --topic")
    return detections[0].name, known[detections[0].msgtype]


def read_recording(path: str, topic: str, kind: Kind) -> Iterator[DetectedObjectArray]:
    """The detection arrays on ``topic`` of a recording, in log-time order."""
    from objrec_ros.bags import open_recording

    try:
        with open_recording(path) as recording:
            for index, (_, message) in enumerate(recording.messages(topic)):
                try:
                    yield kind.object_array_type.from_dict(_plain(message))
                except (ValueError, TypeError, KeyError, AttributeError) as exc:
                    raise InputError(path, f"not detections of the {kind.name} kind: {exc}",
                                     f"{topic} message {index}") from None
    except SourceError as exc:
        raise UserError(str(exc)) from None
