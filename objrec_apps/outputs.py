"""Where objrec-detect's detections go: JSON Lines text, or typed ROS messages in an MCAP file or a bag.

The choice follows ``--output``: ``.mcap``, ``.bag``, and a folder (existing, or a new path without suffix)
get typed messages written by ``objrec_ros.output`` (the ``ros`` extra: rosbags); anything else is a JSON
Lines text file. An existing file without suffix (``/dev/full``, a FIFO) stays text, as before.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from objrec_core import DetectedObjectArray, FrameSource, SourceSpec

from .cli import UserError

#: What the user is told when rosbags is missing.
ROS_EXTRA = "pip install 'objrec[ros]'"
_TOPIC_TOKEN = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def is_typed_output(path: str) -> bool:
    """Whether ``--output path`` asks for typed ROS messages (the rule of ``objrec_ros.output.output_format``,
    kept here so that it is known without rosbags installed)."""
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix in (".mcap", ".bag"):
        return True
    return target.is_dir() or (not suffix and not target.exists() and path not in ("", "-"))


def default_topic(object_name: str) -> str:
    """``/objrec/<object name>`` made a valid ROS 1 and ROS 2 topic name (letters, digits and underscores,
    each name part starting with a letter)."""
    token = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", object_name)).strip("_") or "objects"
    if not token[0].isalpha():
        token = f"object_{token}"
    return f"/objrec/{token}"


def check_topic(topic: str, given_as: str | None = None) -> str:
    """A user's ``--output-topic`` (or the topic of what ``given_as`` names, such as ``--publish ros1:/x``),
    made absolute; refused (one line) where ROS 1 or ROS 2 would refuse it."""
    name = topic.strip()
    absolute = name if name.startswith("/") else f"/{name}"
    parts = absolute[1:].split("/")
    if not name or any(not _TOPIC_TOKEN.fullmatch(p) or "__" in p for p in parts):
        raise UserError(f"{given_as or f'--output-topic {topic!r}'}: not a valid ROS topic name (name parts of "
                        "letters, digits and single underscores, each starting with a letter, separated by /)")
    return absolute


def require_rosbags(option: str) -> None:
    """A one-line UserError saying which extra to install where rosbags is missing."""
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise UserError(f"{option} needs rosbags, which is not installed: {ROS_EXTRA}") from None


def recording_path(spec_text: str) -> Path:
    """The recording a ``--list-topics`` argument names: a plain path, or ``bag:PATH[,options]``."""
    spec = SourceSpec.parse(spec_text, {"bag"})
    if spec.path is not None:
        return spec.path
    named = spec.options.get("path") or (spec.positional[0] if spec.positional else "")
    if not named:
        raise UserError(f"{spec_text}: give the recording's path (bag:PATH or a .bag/.mcap file or bag folder)")
    return Path(named).expanduser()


def input_copy(source: FrameSource) -> Any:
    """What ``--copy-input`` copies: the topics a bag source reads (an image or cloud topic; a depth topic
    with its CameraInfo and colour topics) over its start/end window. Any other source is a user mistake."""
    from objrec_ros.output import InputCopy
    from objrec_ros.source import BagSource

    if not isinstance(source, BagSource):
        raise UserError(f"--copy-input: the source {source.name or source!r} is not a bag, so there is no input "
                        "topic to copy (give a .bag, .mcap or ROS 2 bag folder as --source)")
    extra = (getattr(source, "info_topic", None), getattr(source, "color_topic", None))  # a depth pair's
    topics = (source.topic_info.name, *(t for t in extra if t))
    # the frames' origins: detections logged beside their input messages, under their headers
    return InputCopy(Path(source.recording.path), topics, source.start, source.end, source.origins())


def open_typed_writer(path: str, array_type: type[DetectedObjectArray], topic: str, copy: Any = None) -> Any:
    """The typed-message writer for ``--output``, every failure to open it one UserError line."""
    from objrec_ros.msgdefs import MessageDefinitionError
    from objrec_ros.output import open_detection_writer
    from strictio import OutputError

    try:
        return open_detection_writer(path, array_type, topic, copy_from=copy)
    except OutputError as exc:
        raise UserError(str(exc)) from None
    except MessageDefinitionError as exc:
        raise UserError(f"{path}: these detections cannot be written as ROS messages: {exc}") from None
