"""Recordings in: ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) and bare MCAP files, through rosbags.

``open_recording(path)`` reads any of them with rosbags' ``AnyReader`` and the typestore of the recording's
ROS version (definitions embedded in the recording win; the standard types of ROS 1 Noetic or the newest
ROS 2 fill in what it lacks). Everything a broken or unexpected recording makes rosbags raise (its own
errors, but also ``struct.error``, ``AssertionError`` or SQLite errors from a truncated file) comes out as one
:class:`RecordingError` naming the file, so a user sees one line and not a traceback.

A bare ``.mcap`` file (no ``metadata.yaml`` beside it) is read by rosbags 0.11 and later directly (its
``rosbag2.Reader`` takes the storage file itself); rosbags 0.10 only reads the folder form, which is said
plainly rather than misread as a ROS 1 bag.

rosbags is imported when a recording is opened, not with this module: the kinds' bag sources are loaded with
every other source type, and a user without the ``ros`` extra (or opening a camera) should not pay for it.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from objrec_core import SourceError
from strictio import InputError, LimitError, YAMLLimits, open_input, read_yaml

from .bag_metadata import MetadataError, check_metadata, compression_mode
from .bounded import DeclaredSizeError, check_temp_space
from .bounded import install as install_bounds
from .definitions import DECODED_TYPES, first_difference
from .direct import direct_reader
from .direct import messages as direct_messages

log = logging.getLogger(__name__)

#: The file suffixes of recordings (a ROS 2 bag is a folder with ``metadata.yaml``).
RECORDING_SUFFIXES = (".bag", ".mcap")
#: ``metadata.yaml`` of a ROS 2 bag is small; a bigger one is not a bag's.
METADATA_LIMITS = YAMLLimits(max_bytes=16 * 1024 * 1024, max_depth=30)


class RecordingError(SourceError):
    """A recording that cannot be read as asked: missing, truncated, corrupt, without the topic or type wanted."""

    def __init__(self, path: str | Path, message: str) -> None:
        self.path = str(path)
        self.message = message
        super().__init__(f"{self.path}: {message}")


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a recording: its name, message type (``sensor_msgs/msg/Image``, ROS 1 types named the
    ROS 2 way) and how many messages it holds."""

    name: str
    msgtype: str
    count: int


def is_recording_path(path: str | Path) -> bool:
    """Whether ``path`` looks like a recording: a ``.bag``/``.mcap`` file or a folder with ``metadata.yaml``
    (by name only: opening it tells whether it is a readable one)."""
    path = Path(path)
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.suffix.lower() in RECORDING_SUFFIXES


def _rosbags(path: Path) -> SimpleNamespace:
    """The parts of rosbags used here, or a RecordingError saying which extra to install."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.rosbag2 import Reader as Reader2
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise RecordingError(path, "reading ROS bags and MCAP files needs rosbags: install the ros extra "
                                   "(pip install 'objrec[ros]')") from None
    install_bounds()  # every chunk, message and file rosbags inflates is bounded from here on
    return SimpleNamespace(AnyReader=AnyReader, Reader2=Reader2, Stores=Stores, get_typestore=get_typestore)


def _one_line(exc: BaseException) -> str:
    """An exception as one line of text: rosbags' messages sometimes wrap tuples or span lines."""
    def flat(part: object) -> str:  # rosbags wraps messages in tuples: show the text, not the tuple
        return " ".join(flat(p) for p in part) if isinstance(part, tuple | list) else str(part)

    text = flat(exc.args) if exc.args else ""
    text = re.sub(r"\(['\"](.*?)['\"],\)", r"\1", text)  # a one-element tuple already formatted into the text
    text = " ".join(text.split()) or type(exc).__name__
    return text if len(text) <= 300 else text[:297] + "..."


def _check_file(path: Path, what: str) -> None:
    """Refuse what is not a regular file (a FIFO would block rosbags, a device would be read forever)."""
    try:
        open_input(path, limit=None).close()
    except InputError as exc:
        raise RecordingError(path, f"{what}: {exc.message}") from None


class Recording:
    """An open recording. Use as a context manager (or call ``close``).

    Times: ``start_ns``/``end_ns`` are the log times (nanoseconds since the epoch) of the first message and
    just after the last one; ``start_time`` is ``start_ns`` in seconds and ``duration`` the span in seconds.
    ``start``/``end`` arguments are seconds into the recording (from ``start_time``), as ``rosbag play -s``
    counts them; ``end`` is exclusive and ``None`` leaves that side open.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.format = ""  # "ROS 1 bag", "ROS 2 bag (sqlite3)", "ROS 2 bag (mcap)" or "MCAP file"
        self._rosbags = _rosbags(self.path)
        reader_path = self._check_path()
        stores = self._rosbags.Stores
        self._default = self._rosbags.get_typestore(stores.ROS1_NOETIC if self.is_ros1 else stores.LATEST)
        try:
            self._reader = self._rosbags.AnyReader([reader_path], default_typestore=self._default)
            self._reader.open()
        except FileNotFoundError:
            raise RecordingError(self.path, f"{self.format} not found") from None
        except LimitError as exc:  # a bounded decompression refused
            raise RecordingError(self.path, exc.message) from None
        except DeclaredSizeError as exc:
            raise RecordingError(self.path, f"corrupt: {exc}") from None
        except Exception as exc:  # rosbags reports a broken file with many exception types
            raise RecordingError(self.path, f"not a readable {self.format} (truncated or corrupt?): "
                                            f"{_one_line(exc)}") from None
        self._fill_types()
        #: an uncompressed ROS 1 bag's messages are read one by one from the file (objrec_ros.direct)
        self._direct = direct_reader(self._reader) if self.is_ros1 else None
        self._closed = False

    def _check_path(self) -> Path:
        """The path rosbags is given, after checking it ourselves; sets ``format``."""
        path = self.path
        if path.is_dir():
            metadata = path / "metadata.yaml"
            if not metadata.exists():
                raise RecordingError(path, "a folder without metadata.yaml is not a ROS 2 bag")
            try:
                document = read_yaml(metadata, METADATA_LIMITS)
            except InputError as exc:
                raise RecordingError(path, f"metadata.yaml: {exc.message}") from None
            info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
            if not isinstance(info, dict):
                raise RecordingError(path, "metadata.yaml: not a ROS 2 bag's metadata "
                                           "(no rosbag2_bagfile_information mapping)")
            storage = str(info.get("storage_identifier", "?"))
            self.format = f"ROS 2 bag ({storage})"
            try:
                check_metadata(info)
            except MetadataError as exc:
                raise RecordingError(path, str(exc)) from None
            files = [path / Path(str(name)).name for name in info["relative_file_paths"]]
            for file in files:
                if file.exists():
                    _check_file(file, f"storage file {file.name}")
            if compression_mode(info) == "file" and all(f.exists() for f in files):
                try:
                    check_temp_space(files)  # before rosbags inflates them into the temp folder
                except InputError as exc:
                    raise RecordingError(path, exc.message) from None
                except Exception as exc:  # not zstd, or truncated: what rosbags would say later, said now
                    raise RecordingError(path, f"compressed storage files cannot be read: {_one_line(exc)}") from None
            return path
        suffix = path.suffix.lower()
        if suffix == ".bag":
            self.format = "ROS 1 bag"
        elif suffix == ".mcap":
            self.format = "MCAP file"
            if ".mcap" not in getattr(self._rosbags.Reader2, "STORAGE_PLUGINS", {}):
                raise RecordingError(path, "reading a bare .mcap file needs rosbags 0.11 or later; put it in a "
                                           "ROS 2 bag folder with its metadata.yaml, or upgrade rosbags")
        elif suffix == ".db3":
            self.format = "ROS 2 sqlite3 file"
        else:
            raise RecordingError(path, "not a recording (a .bag or .mcap file, or a ROS 2 bag folder with "
                                       "metadata.yaml)")
        if not path.exists():
            raise RecordingError(path, f"{self.format} not found")
        _check_file(path, self.format)
        return path

    def _fill_types(self) -> None:
        """Add the standard types a recording uses without defining them (a recording defines some or all)."""
        store = self._reader.typestore
        missing = {c.msgtype for c in self._reader.connections} - set(store.fielddefs)
        if not missing:
            return
        extra = {name: fields for name, fields in self._default.fielddefs.items() if name not in store.fielddefs}
        try:
            store.register(extra)
        except Exception as exc:  # a recording whose own definitions clash with the standard ones
            log.warning("%s: standard types not added: %s", self.path, _one_line(exc))

    # -- what the recording holds -------------------------------------------------------------------------
    @property
    def typestore(self) -> Any:
        """The typestore messages are decoded with (for re-serializing them, e.g. when copying a topic)."""
        return self._reader.typestore

    @property
    def is_ros1(self) -> bool:
        return self.format == "ROS 1 bag"

    @property
    def start_ns(self) -> int:
        return self._reader.start_time if self.message_count else 0

    @property
    def end_ns(self) -> int:
        return self._reader.end_time if self.message_count else 0

    @property
    def start_time(self) -> float:
        """Log time of the first message, seconds since the epoch (0 for an empty recording)."""
        return self.start_ns / 1e9

    @property
    def duration(self) -> float:
        """Seconds from the first message to just after the last."""
        return (self.end_ns - self.start_ns) / 1e9

    @property
    def message_count(self) -> int:
        return int(self._reader.message_count)

    def topics(self) -> list[TopicInfo]:
        """Every topic, by name."""
        found = []
        for name, info in sorted(self._reader.topics.items()):
            msgtype = info.msgtype or "/".join(sorted({c.msgtype for c in info.connections}))
            found.append(TopicInfo(name, msgtype, int(info.msgcount)))
        return found

    def topic(self, name: str) -> TopicInfo:
        """The topic ``name``; RecordingError listing the topics when there is none."""
        for info in self.topics():
            if info.name == name:
                return info
        known = ", ".join(t.name for t in self.topics()) or "none"
        raise RecordingError(self.path, f"no topic {name} (topics: {known})")

    def knows_type(self, msgtype: str) -> bool:
        """Whether messages of ``msgtype`` can be decoded (defined in the recording or a standard type)."""
        return msgtype in self._reader.typestore.fielddefs

    # -- messages -----------------------------------------------------------------------------------------
    def _window(self, start: float | None, end: float | None) -> tuple[int | None, int | None]:
        base = self.start_ns
        first = None if start is None else base + math.floor(start * 1e9)
        stop = None if end is None else base + math.floor(end * 1e9)
        return first, stop

    def _connections(self, topics: Iterable[str], decoded: bool) -> list[Any]:
        wanted = list(dict.fromkeys(topics))
        connections = []
        for name in wanted:
            info = self.topic(name)
            if decoded and not self.knows_type(info.msgtype):
                raise RecordingError(self.path, f"topic {name}: message type {info.msgtype} is neither defined "
                                                "in the recording nor a standard ROS type")
            if decoded and info.msgtype in DECODED_TYPES:
                lie = first_difference(self._reader.typestore, self._default, info.msgtype)
                if lie:
                    raise RecordingError(self.path, f"topic {name}: the recording defines {info.msgtype} unlike "
                                                    f"the standard type: {lie}")
            connections.extend(c for c in self._reader.connections if c.topic == name)
        return connections

    def raw_messages(self, topics: str | Iterable[str], start: float | None = None, end: float | None = None,
                     *, decodable: bool = False) -> Iterator[tuple[str, int, str, bytes | bytearray]]:
        """``(topic, log_time_ns, msgtype, serialized bytes)`` in log-time order, undecoded (ROS 1 or CDR
        serialization as the recording has it: ``is_ros1``). ``decodable`` first checks that the types are
        known, as decoding needs."""
        self._check_open()
        names = [topics] if isinstance(topics, str) else list(topics)
        connections = self._connections(names, decodable)
        first, stop = self._window(start, end)
        if not connections:
            return
        try:
            if self._direct is not None:
                found = direct_messages(self._direct, connections, first, stop)
            else:
                found = self._reader.messages(connections, start=first, stop=stop)
            for connection, log_time, raw in found:
                yield connection.topic, int(log_time), connection.msgtype, raw
        except RecordingError:
            raise
        except LimitError as exc:  # a bounded decompression refused
            raise RecordingError(self.path, f"{', '.join(names)}: {exc.message}") from None
        except DeclaredSizeError as exc:  # compressed data that does not fit what its container says
            raise RecordingError(self.path, f"{', '.join(names)}: corrupt: {exc}") from None
        except Exception as exc:
            raise RecordingError(self.path, f"{', '.join(names)}: cannot be read further (truncated or "
                                            f"corrupt?): {_one_line(exc)}") from None

    def merged(self, topics: Iterable[str], start: float | None = None, end: float | None = None
               ) -> Iterator[tuple[str, int, Any]]:
        """``(topic, log_time_ns, message)`` of several topics in log-time order, decoded."""
        counts: dict[str, int] = {}
        for topic, log_time, msgtype, raw in self.raw_messages(topics, start, end, decodable=True):
            index = counts.get(topic, 0)
            counts[topic] = index + 1
            try:
                message = self._reader.deserialize(raw, msgtype)
            except Exception as exc:
                raise RecordingError(self.path, f"{topic}: message {index} ({msgtype}) cannot be decoded: "
                                                f"{_one_line(exc)}") from None
            yield topic, log_time, message

    def messages(self, topic: str, start: float | None = None, end: float | None = None
                 ) -> Iterator[tuple[int, Any]]:
        """``(log_time_ns, message)`` of one topic, decoded, in log-time order."""
        for _, log_time, message in self.merged([topic], start, end):
            yield log_time, message

    def log_times(self, topic: str, start: float | None = None, end: float | None = None) -> list[int]:
        """The log times of a topic's messages (read, not decoded): for counts and rates within a window."""
        return [log_time for _, log_time, _, _ in self.raw_messages(topic, start, end)]

    def first(self, topic: str, start: float | None = None, end: float | None = None) -> tuple[int, Any] | None:
        """The first message of a topic in the window, or None."""
        messages = self.messages(topic, start, end)
        try:
            return next(messages, None)
        finally:
            messages.close()

    # -- life -----------------------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise RecordingError(self.path, "the recording is closed")

    def close(self) -> None:
        if not getattr(self, "_closed", True):
            self._closed = True
            try:
                self._reader.close()
            except Exception as exc:  # closing a broken file must not hide the error that led here
                log.debug("%s: closing: %s", self.path, _one_line(exc))

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Recording({str(self.path)!r}, {self.format})"


def open_recording(path: str | Path) -> Recording:
    """Open a ROS 1 ``.bag``, a ROS 2 bag folder (sqlite3 or MCAP storage) or a bare ``.mcap`` file.

    RecordingError (a SourceError) names the file for a missing, truncated or corrupt recording.
    """
    return Recording(Path(path).expanduser())


def header_stamp(message: Any, log_time_ns: int) -> float:
    """The header stamp of ``message`` in seconds, or its log time where the header has none (zero)."""
    header = getattr(message, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is not None:
        sec = getattr(stamp, "sec", 0)
        nanosec = getattr(stamp, "nanosec", 0)
        if sec or nanosec:
            return sec + nanosec * 1e-9
    return log_time_ns / 1e9


def header_stamp_ns(message: Any, log_time_ns: int) -> int:
    """The header stamp of ``message`` in nanoseconds, exactly, or its log time where the header has none."""
    stamp = getattr(getattr(message, "header", None), "stamp", None)
    if stamp is not None:
        exact = int(getattr(stamp, "sec", 0)) * 1_000_000_000 + int(getattr(stamp, "nanosec", 0))
        if exact:
            return exact
    return int(log_time_ns)


def header_frame_id(message: Any) -> str:
    """The header's frame_id, or "" for a message without a header."""
    return str(getattr(getattr(message, "header", None), "frame_id", "") or "")


def topics_table(topics: Iterable[TopicInfo]) -> str:
    """Topics as an aligned table: topic, type, count."""
    rows = [("topic", "type", "messages")] + [(t.name, t.msgtype, str(t.count)) for t in topics]
    widths = [max(len(row[i]) for row in rows) for i in range(2)]
    return "\n".join(f"{a:<{widths[0]}}  {b:<{widths[1]}}  {c:>8}".rstrip() for a, b, c in rows)


def list_topics(path: str | Path) -> str:
    """The text ``objrec-detect --list-topics`` prints: a table of topics, types and message counts, and a
    last line with the recording's format, message count and duration."""
    with open_recording(path) as recording:
        topics = recording.topics()
        table = topics_table(topics)
        plural = "" if len(topics) == 1 else "s"
        summary = (f"{recording.format}, {len(topics)} topic{plural}, {recording.message_count} messages, "
                   f"{recording.duration:.3f} s")
    return f"{table}\n{summary}"
