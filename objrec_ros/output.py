"""Detections out as typed ROS messages: an MCAP file, a ROS 1 bag, or a ROS 2 bag folder.

``open_detection_writer(path, array_type, topic)`` gives a sink: each call writes one detected-object array
as a typed message (the array class's ``ros_type``, its definitions embedded), logged at the input frame's
stamp. The format follows the path: ``.mcap`` a single MCAP file (ROS 2 CDR messages; rosbags and the
``mcap`` reader both open it as it is), ``.bag`` a ROS 1 bag, a path without suffix (or an existing folder)
a ROS 2 bag folder with MCAP storage. ROS 2 headers have no ``seq``; ROS 1 headers keep it.

Everything is written under a hidden temporary name next to the target (one a later writer recognises and
removes if this process was killed) and moved into place by ``close``: the output is complete or absent,
never half written. With ``copy_from`` the writer also copies the topics of
an input recording (its raw messages, type and connection) so the output replays with its detections.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import shutil
import stat
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader
from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag1,
    ConnectionExtRosbag2,
    MessageDefinitionFormat,
    Nodetype,
)
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys.store import Typestore

from objrec_core import DetectedObjectArray
from strictio import OutputError
from strictio.atomic import is_read_only, remove_stale_temporaries, temporary_path

from .bounded import install as install_bounds
from .direct import direct_reader
from .direct import messages as direct_messages
from .encode import DetectionEncoder
from .msgdefs import standard_typestore
from .source import Origins

log = logging.getLogger(__name__)

#: Output formats by what the path looks like.
MCAP, ROS1_BAG, ROS2_FOLDER = "mcap", "ros1", "ros2"
_FOLDER_FILES = {"metadata.yaml"}
_STORAGE_SUFFIXES = (".mcap", ".db3", ".zstd")


def output_format(path: str | os.PathLike[str]) -> str | None:
    """The typed format ``path`` asks for (MCAP, ROS1_BAG, ROS2_FOLDER), or None for a text file.

    ``.mcap`` and ``.bag`` by suffix; an existing folder, or a path without suffix that is not an existing
    file (``/dev/full`` stays a file), is a ROS 2 bag folder.
    """
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix == ".mcap":
        return MCAP
    if suffix == ".bag":
        return ROS1_BAG
    if target.is_dir() or (not suffix and not target.exists() and str(path) not in ("", "-")):
        return ROS2_FOLDER
    return None


@dataclass(frozen=True)
class InputCopy:
    """The topics of an input recording to copy next to the detections (what a bag source read: an image
    topic, or a depth topic with its CameraInfo and colour topics).

    ``path`` is what rosbags opens (a ``.bag`` file, a ``.mcap`` file, a ROS 2 bag folder); ``start`` and
    ``end`` are seconds from the recording's first message (``end`` exclusive), as a bag source counts them.
    """

    path: Path
    topics: tuple[str, ...]
    start: float | None = None
    end: float | None = None
    #: The source's record of its frames' input messages (``BagSource.origins()``): with it a detection is
    #: logged at its input's log time under its input's header, so both share one timeline.
    origins: Origins | None = None


class DetectionWriter:
    """Writes detected-object arrays as typed messages on one topic; see the module docstring.

    ``writer(array)`` writes one message (log time = the header stamp); ``close()`` finishes the file and moves
    it into place; ``abort()`` (or leaving the ``with`` block by an exception) leaves nothing behind. Every
    failure to write is a ``strictio.OutputError`` naming the output (or the input being copied).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        array_type: type[DetectedObjectArray],
        topic: str,
        *,
        copy_from: InputCopy | None = None,
        fmt: str | None = None,
    ) -> None:
        self.shown = str(path)
        self.format = fmt or output_format(path)
        if self.format not in (MCAP, ROS1_BAG, ROS2_FOLDER):
            raise OutputError(self.shown, "is neither a .mcap file, a .bag file nor a ROS 2 bag folder")
        self.topic = topic
        self.ros_version = 1 if self.format == ROS1_BAG else 2
        self.count = 0
        self._encoder = DetectionEncoder(array_type, self.ros_version)  # the bytes a live publisher sends too
        self._ros_type = self._encoder.ros_type
        self.typestore = self._encoder.typestore
        self._target = self._check_target(Path(os.path.realpath(path)))  # a link: its target is replaced
        self._tmpdir: Path | None = None
        self._writer: Writer1 | Writer2 | None = None
        self._copy: _InputCopy | None = None
        try:
            self._open()
            self._connection = self._add_connection(topic, self._ros_type, self.typestore)
            if copy_from is not None:
                self._copy = _InputCopy(copy_from, self)
        except BaseException:
            self.abort()
            raise

    # -- opening -----------------------------------------------------------------------------------------
    def _check_target(self, target: Path) -> Path:
        """Refuse what must not be replaced before any work is done: a device, a read-only file, a folder
        holding other things than a bag."""
        try:
            info = target.stat()
        except FileNotFoundError:
            return target
        except OSError as exc:
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}") from None
        if self.format == ROS2_FOLDER:
            if not stat.S_ISDIR(info.st_mode):
                raise OutputError(self.shown, "exists and is not a folder")
            entries = {p.name for p in target.iterdir()}
            bag = "metadata.yaml" in entries and all(
                n in _FOLDER_FILES or n.endswith(_STORAGE_SUFFIXES) for n in entries
            )
            if entries and not bag:
                raise OutputError(self.shown, "is a folder holding other files than a ROS 2 bag; give a new or "
                                              "empty folder (or a bag folder to replace)")
        elif not stat.S_ISREG(info.st_mode):
            raise OutputError(self.shown, "exists and is not a regular file")
        elif is_read_only(target, info):
            raise OutputError(self.shown, "cannot be written: the file is read-only")
        return target

    def _open(self) -> None:
        folder = self._target.parent
        try:
            folder.mkdir(parents=True, exist_ok=True)
            remove_stale_temporaries(folder)  # of writers killed before they could clean up
            self._tmpdir = temporary_path(self._target)
            self._tmpdir.mkdir(mode=0o700)
            inner = self._tmpdir / (self._target.stem if self.format == MCAP else self._target.name)
            if self.format == ROS1_BAG:
                self._writer = Writer1(inner)
            else:
                self._writer = Writer2(inner, version=Writer2.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
                # zstd-compressed MCAP chunks: what ros2 bag record writes with --compression-mode storage,
                # readable by the mcap reader and rosbags alike (the bag's metadata says no file compression)
                self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
            self._writer.open()
        except OSError as exc:
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}") from None
        except Exception as exc:  # rosbags' WriterError
            raise OutputError(self.shown, f"cannot be written: {exc}") from None

    def _add_connection(self, topic: str, msgtype: str, typestore: Typestore, source: Connection | None = None) -> Any:
        """A connection for ``msgtype``: with the definition generated from ``typestore``, or as ``source``
        has it (same ROS version)."""
        writer = self._writer
        assert writer is not None
        try:
            if isinstance(writer, Writer1):
                ext1 = source.ext if source is not None and isinstance(source.ext, ConnectionExtRosbag1) else None
                if source is not None and ext1 is not None and source.digest and _has_definition(source):
                    return writer.add_connection(topic, msgtype, msgdef=source.msgdef.data, md5sum=source.digest,
                                                 callerid=ext1.callerid, latching=ext1.latching)
                return writer.add_connection(topic, msgtype, typestore=typestore,
                                             latching=ext1.latching if ext1 is not None else None)
            ext2 = source.ext if source is not None and isinstance(source.ext, ConnectionExtRosbag2) else None
            qos = ext2.offered_qos_profiles if ext2 is not None else ()
            if source is not None and ext2 is not None and source.digest and _has_definition(source):
                return writer.add_connection(topic, msgtype, msgdef=source.msgdef.data, rihs01=source.digest,
                                             offered_qos_profiles=qos)
            return writer.add_connection(topic, msgtype, typestore=typestore, offered_qos_profiles=qos)
        except OSError as exc:
            self.abort()
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}") from None
        except Exception as exc:
            self.abort()
            raise OutputError(self.shown, f"topic {topic}: {exc}") from None

    # -- writing -----------------------------------------------------------------------------------------
    def __call__(self, array: DetectedObjectArray) -> None:
        """Write one array as a message, logged at its header stamp (after the copied input up to then); with a
        copied input whose source records its frames' origins, at its input message's log time and under that
        message's header exactly (a stamp of 0 and an empty frame_id included)."""
        if self._writer is None:
            raise OutputError(self.shown, "is closed")
        stamp = array.header.to_dict()["stamp"]
        log_time = int(stamp["secs"]) * 1_000_000_000 + int(stamp["nsecs"])
        header = None
        origins = self._copy.spec.origins if self._copy is not None else None
        origin = origins.take(log_time) if origins is not None else None
        if origin is not None:
            log_time = origin.log_ns
            secs, nsecs = divmod(origin.stamp_ns, 1_000_000_000)
            header = {"stamp": {"secs": secs, "nsecs": nsecs}, "frame_id": origin.frame_id}
        raw = self._encoder(array, header)
        if self._copy is not None:
            self._copy.until(log_time)
        self._write(self._connection, log_time, raw)
        self.count += 1

    def _write(self, connection: Any, log_time: int, raw: Any) -> None:
        try:
            assert self._writer is not None
            self._writer.write(connection, max(log_time, 0), raw)
        except OSError as exc:
            self.abort()
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}") from None

    def close(self) -> None:
        """Finish the output (the rest of a copied input first) and move it into place."""
        if self._writer is None:
            return
        try:
            if self._copy is not None:
                self._copy.until(None)
                self._copy.close()
                self._copy = None
            self._writer.close()
            self._writer = None
            self._commit()
        except OutputError:
            self.abort()
            raise
        except OSError as exc:
            self.abort()
            raise OutputError(self.shown, f"cannot be written: {exc.strerror or exc}") from None
        except Exception as exc:
            self.abort()
            raise OutputError(self.shown, f"cannot be written: {exc}") from None
        log.info("%d messages written to %s on %s", self.count, self.shown, self.topic)

    def _commit(self) -> None:
        assert self._tmpdir is not None
        written = self._tmpdir / self._target.name
        if self.format == MCAP:
            written = self._tmpdir / self._target.stem / f"{self._target.stem}.mcap"
        files = [written] if written.is_file() else sorted(p for p in written.iterdir() if p.is_file())
        for file in files:
            with file.open("rb") as stream:
                os.fsync(stream.fileno())
        if self.format == ROS2_FOLDER and self._target.is_dir() and any(self._target.iterdir()):
            old = self._tmpdir / ".replaced"
            os.replace(self._target, old)  # a bag folder written before: set aside, dropped below
        os.replace(written, self._target)
        shutil.rmtree(self._tmpdir, ignore_errors=True)
        self._tmpdir = None

    def abort(self) -> None:
        """Stop writing and leave nothing behind (a target that existed before stays as it was)."""
        writer, self._writer = self._writer, None
        if writer is not None:
            with contextlib.suppress(Exception):
                writer.abort()
        copy, self._copy = self._copy, None
        if copy is not None:
            with contextlib.suppress(Exception):
                copy.close()
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None

    def __enter__(self) -> DetectionWriter:
        return self

    def __exit__(self, exc_type: object, *_exc: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


class _InputCopy:
    """Topics of an input recording, copied into a writer's output in log-time order with the detections.

    Within one ROS version the raw messages and the input's connections (definition, hash, QoS or callerid)
    are copied as they are; between ROS 1 and ROS 2 each message is re-serialised (a header gains or loses
    its seq), which rosbags does for types laid out alike in both.
    """

    def __init__(self, spec: InputCopy, writer: DetectionWriter) -> None:
        self.spec = spec
        self.writer = writer
        self.shown = str(spec.path)
        self._pending: tuple[int, Any, Any] | None = None
        path = Path(spec.path)
        install_bounds()  # the copy inflates the input's chunks as its source does: bounded
        try:
            self.reader = AnyReader([path], default_typestore=standard_typestore(1 if path.suffix == ".bag" else 2))
            self.reader.open()
        except Exception as exc:  # rosbags' reader errors, OSError
            raise OutputError(self.shown, f"cannot be copied: {exc}") from None
        try:
            self._messages = self._select()
        except BaseException:
            self.close()
            raise

    def _select(self) -> Iterator[tuple[int, Any, Any]]:
        spec, reader, writer = self.spec, self.reader, self.writer
        same_version = reader.is2 == (writer.ros_version == 2)
        targets: dict[str, tuple[Any, Callable[[Any], Any] | None]] = {}
        connections: list[Connection] = []
        for topic in dict.fromkeys(spec.topics):
            if topic == writer.topic:
                raise OutputError(writer.shown, f"topic {topic} would hold both the input and the detections; "
                                                "choose another output topic")
            found = [c for c in reader.connections if c.topic == topic]
            if not found:
                topics = ", ".join(sorted({c.topic for c in reader.connections})) or "none"
                raise OutputError(self.shown, f"has no topic {topic} to copy (topics: {topics})")
            types = {c.msgtype for c in found}
            if len(types) > 1:
                raise OutputError(self.shown, f"topic {topic} holds several types ({', '.join(sorted(types))})")
            msgtype = types.pop()
            if same_version:
                targets[topic] = writer._add_connection(topic, msgtype, reader.typestore, found[0]), None
            else:
                convert = self._converter(topic, msgtype)
                targets[topic] = writer._add_connection(topic, msgtype, writer.typestore), convert
            connections.extend(found)
        first = reader.start_time
        start = first + _ns(spec.start) if spec.start is not None else None
        stop = first + _ns(spec.end) if spec.end is not None else None
        return self._iterate(connections, targets, start, stop)

    def _iterate(self, connections: list[Connection], targets: dict[str, tuple[Any, Callable[[Any], Any] | None]],
                 start: int | None, stop: int | None) -> Iterator[tuple[int, Any, Any]]:
        direct = direct_reader(self.reader)  # an uncompressed ROS 1 bag: one message at a time, not whole chunks
        found = (direct_messages(direct, connections, start, stop) if direct is not None
                 else self.reader.messages(connections, start=start, stop=stop))
        for connection, log_time, raw in found:
            target, convert = targets[connection.topic]
            yield log_time, target, raw if convert is None else convert(raw)

    def _converter(self, topic: str, msgtype: str) -> Callable[[Any], Any]:
        """ROS 1 <-> ROS 2 serialisation for ``msgtype``, refused where the layouts differ."""
        source, store = self.reader.typestore, self.writer.typestore
        missing = {n: d for n, d in source.fielddefs.items() if n not in store.fielddefs}
        if missing:
            store.register(missing)
        if not _same_layout(source, store, msgtype):
            raise OutputError(self.shown, f"topic {topic}: its type {msgtype} is laid out differently in ROS 1 "
                                          "and ROS 2, so it cannot be copied into this format")
        if self.reader.is2:
            return lambda raw: source.cdr_to_ros1(raw, msgtype)
        return lambda raw: store.ros1_to_cdr(raw, msgtype)

    def until(self, log_time: int | None) -> None:
        """Write the input's messages logged at or before ``log_time`` (all the rest with None)."""
        while True:
            if self._pending is None:
                try:
                    self._pending = next(self._messages)
                except StopIteration:
                    return
                except OutputError:
                    raise
                except Exception as exc:  # a truncated or corrupt input found while copying
                    raise OutputError(self.shown, f"cannot be copied: {exc}") from None
            stamp, connection, raw = self._pending
            if log_time is not None and stamp > log_time:
                return
            self.writer._write(connection, stamp, raw)
            self._pending = None

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.reader.close()


def _ns(seconds: float) -> int:
    return math.floor(seconds * 1e9)


def _has_definition(connection: Connection) -> bool:
    return connection.msgdef.format != MessageDefinitionFormat.NONE and bool(connection.msgdef.data)


def _same_layout(source: Typestore, target: Typestore, msgtype: str) -> bool:
    """Whether both stores lay ``msgtype`` out alike (a header's seq aside, which the converters handle)."""
    if msgtype == "std_msgs/msg/Header":
        return True
    if msgtype not in source.fielddefs or msgtype not in target.fielddefs:
        return False
    have, want = source.fielddefs[msgtype][1], target.fielddefs[msgtype][1]
    if len(have) != len(want):
        return False
    for (_, a), (_, b) in zip(have, want, strict=True):
        if a != b:
            return False
        inner = a[1][0] if a[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else a
        if inner[0] == Nodetype.NAME and not _same_layout(source, target, inner[1]):
            return False
    return True


def open_detection_writer(
    path: str | os.PathLike[str],
    array_type: type[DetectedObjectArray],
    topic: str,
    *,
    copy_from: InputCopy | None = None,
) -> DetectionWriter:
    """A sink writing ``array_type`` arrays as typed messages on ``topic`` into ``path`` (format by path)."""
    return DetectionWriter(path, array_type, topic, copy_from=copy_from)
