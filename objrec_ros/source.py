"""What the kinds' bag sources share: the spec, the recording, the window, the replay pace and the topic choice.

``objrec2d.bag_source.ImageBagSource`` and ``objrec3d.bag_source.CloudBagSource`` subclass :class:`BagSource`;
each chooses its topics and turns messages into its frames. Spec: ``bag:PATH[,topic=NAME,start=S,end=S,
rate=R]``, or the plain path of a ``.bag``/``.mcap`` file or a ROS 2 bag folder (then with the defaults).

- ``start``/``end``: seconds into the recording (from its first message, any topic), as ``rosbag play -s``
  counts them; without ``end`` it reads to the end (the old ``end=0`` still does).
- ``rate``: the replay pace against the recorded log times: 1 as recorded, 2 twice as fast, 0.5 half as fast;
  without it (the default) frames are read as fast as they are asked for, which is what a batch run wants.
- Each frame carries the message's header stamp (its log time where the header stamp is zero) and frame_id;
  ``origins()`` also records each frame's log time and header as recorded, for an output that copies the input.
"""

from __future__ import annotations

import logging
import threading
import time
from abc import abstractmethod
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from objrec_core import Float, Frame, FrameSource, SourceError, SourceSpec, Str

from .bags import RECORDING_SUFFIXES, Recording, RecordingError, TopicInfo, is_recording_path, open_recording
from .decode import DecodeError

log = logging.getLogger(__name__)

#: One frame as a kind's source makes it: (log time ns, header stamp ns (0 where the header has none), frame_id,
#: data).
Decoded = tuple[int, int, str, Any]


@dataclass(frozen=True)
class Origin:
    """The input message behind a frame: its log time and its header as recorded (stamp 0 and an empty
    frame_id kept), so that an output copying the input puts a detection on the input's timeline."""

    frame_stamp_ns: int  # the frame's stamp_ns (the header stamp, or the log time where it is 0)
    log_ns: int
    stamp_ns: int  # the header stamp as recorded (0: none)
    frame_id: str


class Origins:
    """The origins of the frames a bag source has yielded and whose detections are not written yet.

    ``take(stamp_ns)`` finds the frame of a detection by its stamp (frames come in order, so everything before
    it is dropped): the record holds only frames between the source and the writer, never the whole run."""

    def __init__(self) -> None:
        self._pending: deque[Origin] = deque()
        self._lock = threading.Lock()

    def add(self, origin: Origin) -> None:
        with self._lock:
            self._pending.append(origin)
            while len(self._pending) > MAX_PENDING_ORIGINS:
                self._pending.popleft()

    def take(self, frame_stamp_ns: int) -> Origin | None:
        with self._lock:
            for index, origin in enumerate(self._pending):
                if origin.frame_stamp_ns == frame_stamp_ns:
                    for _ in range(index + 1):
                        self._pending.popleft()
                    return origin
        return None


#: Frames a source may run ahead of its detections' writer (a director's queue is far shorter).
MAX_PENDING_ORIGINS = 1024


def topic_names(topics: Sequence[TopicInfo]) -> str:
    return ", ".join(t.name for t in topics) or "none"


def topics_with_types(topics: Sequence[TopicInfo]) -> str:
    return ", ".join(f"{t.name} ({t.msgtype})" for t in topics) or "none"


class BagSource(FrameSource):
    """Frames of one topic of a recording (a subclass per kind). Opening checks the topic and decodes its
    first message in the window, so a recording objrec cannot read fails before any frame is asked for."""

    schemes = ("bag",)
    extensions = RECORDING_SUFFIXES
    options = {  # noqa: RUF012 - declarations, never mutated
        "path": Str("", "the recording: a .bag or .mcap file, or a ROS 2 bag folder"),
        "topic": Str("", "the topic to read (default: the only one this kind can read)"),
        "start": Float(0.0, "seconds into the recording to start at", min=0.0),
        "end": Float(None, "seconds into the recording to stop before (none: its end)", min=0.0, min_open=True,
                     optional=True, deprecated={0.0: None}),
        "rate": Float(None, "replay pace: 1 as recorded, 2 twice as fast; none: as fast as frames are read",
                      min=0.0, min_open=True, max=1000.0, optional=True, deprecated={0.0: None}),
    }
    positional = ("path",)
    #: What this kind calls the topics it reads, for messages ("image", "point-cloud").
    noun: ClassVar[str] = "readable"
    #: The message types it reads, for messages.
    readable_types: ClassVar[str] = ""

    @classmethod
    def path_score(cls, path: Path) -> int:
        """2 for a .bag/.mcap file or a folder with metadata.yaml: a ROS 2 bag folder beats a folder of images."""
        return 2 if is_recording_path(path) else 0

    @classmethod
    def recording_path(cls, spec: SourceSpec, options: dict[str, Any]) -> str:
        """The recording a spec names: its path, or ``bag:``'s ``path`` option."""
        if spec.scheme is None:
            return str(spec.path)
        if not options["path"]:
            raise SourceError(f"{spec.text}: no recording given (bag:PATH[,topic=NAME,start=S,end=S,rate=R])")
        return str(options["path"])

    def __init__(self, path: str | Path, *, topic: str = "", start: float = 0.0, end: float | None = None,
                 rate: float | None = None, name: str | None = None) -> None:
        self.name = name or str(path)
        end = end or 0.0  # none (or the old 0): to the end of the recording
        rate = rate or 0.0  # none (or the old 0): as fast as frames are asked for
        if start < 0 or end < 0 or rate < 0:
            raise SourceError(f"{self.name}: start, end and rate must not be negative")
        if end and end <= start:
            raise SourceError(f"{self.name}: end={end:g} must come after start={start:g}")
        self.pace = float(rate)
        self.recording: Recording = open_recording(path)
        try:
            if not self.recording.message_count:
                raise RecordingError(self.recording.path, "the recording holds no messages")
            if start and start >= self.recording.duration:
                raise SourceError(f"{self.name}: start={start:g} lies past the end of the recording "
                                  f"({self.recording.duration:.3f} s)")
            self.start: float | None = start or None
            self.end: float | None = end or None
            self._times: list[int] | None = None
            self._origins: Origins | None = None
            self.topic_info = self._select(topic)
        except BaseException:
            self.recording.close()
            raise

    # -- choosing the topic -----------------------------------------------------------------------------
    @abstractmethod
    def _select(self, topic: str) -> TopicInfo:
        """Choose and check the topic (and whatever goes with it); raise RecordingError when unusable."""

    @abstractmethod
    def _decoded(self) -> Iterator[Decoded]:
        """The frames' parts in order; DecodeError and RecordingError are reported by ``__iter__``."""

    def error(self, message: str) -> RecordingError:
        return RecordingError(self.recording.path, message)

    def choose(self, wanted: str, candidates: Callable[[], Sequence[TopicInfo]]) -> TopicInfo:
        """The topic asked for, or the only candidate; errors list the candidates (or every topic).

        ``candidates`` is called only where needed (finding them may read a message of each topic)."""
        if wanted:
            for info in self.recording.topics():
                if info.name == wanted:
                    return info
            raise self.error(f"no topic {wanted} ({self.noun} topics: {topic_names(candidates())})")
        found = candidates()
        if len(found) == 1:
            return found[0]
        if not found:
            raise self.error(f"no {self.noun} topic ({self.readable_types}); its topics: "
                             f"{topics_with_types(self.recording.topics())}")
        raise self.error(f"several {self.noun} topics ({topic_names(found)}); choose one with "
                         f"bag:{self.recording.path},topic=NAME")

    def wrong_type(self, info: TopicInfo, candidates: Sequence[TopicInfo]) -> RecordingError:
        return self.error(f"topic {info.name} holds {info.msgtype}, which a {self.kind} bag source cannot read "
                          f"({self.readable_types}; {self.noun} topics: {topic_names(candidates)})")

    def first_message(self, topic: str, windowed: bool = True) -> tuple[int, Any]:
        """The first message of ``topic`` (in the window): RecordingError when there is none."""
        found = self.recording.first(topic, self.start, self.end) if windowed else self.recording.first(topic)
        if found is None:
            if windowed and (self.start or self.end):
                raise self.error(f"topic {topic} has no messages between {self.start or 0:g} s and "
                                 f"{self.end or self.recording.duration:g} s")
            raise self.error(f"topic {topic} has no messages")
        return found

    def check(self, topic: str, index: int, make: Any, *args: Any) -> Any:
        """``make(*args)``, a DecodeError reported as this recording's, topic's and message's error."""
        try:
            return make(*args)
        except DecodeError as exc:
            raise self.error(f"{topic}: message {index}: {exc}") from None

    # -- the frames -------------------------------------------------------------------------------------
    def _log_times(self) -> list[int]:
        if self._times is None:
            self._times = self.recording.log_times(self.topic_info.name, self.start, self.end)
        return self._times

    @property
    def length(self) -> int:
        """Messages of the topic in the window (counted from the index when there is no window)."""
        if self.start is None and self.end is None:
            return self.topic_info.count
        return len(self._log_times())

    @property
    def rate(self) -> float | None:
        """The topic's mean frequency in the window (messages per second of log time)."""
        times = self._log_times()
        if len(times) < 2 or times[-1] <= times[0]:
            return None
        return (len(times) - 1) / ((times[-1] - times[0]) / 1e9)

    @property
    def seekable(self) -> bool:
        """The topic's log times are indexed, so any of its messages can be the first read."""
        return True

    def frames_from(self, index: int) -> Iterator[Frame]:
        """From the topic's ``index``-th message in the window on: reading starts at its log time (nothing
        before it is decoded). A depth topic paired with CameraInfo numbers its frames by depth message."""
        times = self._log_times()
        if index <= 0:
            return self._frames(0, None)
        if index >= len(times):
            return iter(())
        return self._frames(index, times[index])

    def __iter__(self) -> Iterator[Frame]:
        return self._frames(0, None)

    def _decoded_from(self, first_log: int | None) -> Iterator[Decoded]:
        """``_decoded`` with the window opened at ``first_log`` (ns), messages before it dropped."""
        decoded = self._decoded()
        if first_log is None:
            yield from decoded
            return
        saved, self.start = self.start, (first_log - self.recording.start_ns) / 1e9
        try:
            first = next(decoded, None)  # the subclass reads the window when it starts reading
        finally:
            self.start = saved
        if first is None:
            return
        if first[0] >= first_log:
            yield first
        for item in decoded:
            if item[0] >= first_log:
                yield item

    def origins(self) -> Origins:
        """From now on, record each frame's input message (for ``--copy-input``: detections at its log time,
        under its header)."""
        if self._origins is None:
            self._origins = Origins()
        return self._origins

    def _frames(self, first_index: int, first_log: int | None) -> Iterator[Frame]:
        index = first_index
        wall0 = log0 = None
        try:
            for log_time, header_ns, frame_id, data in self._decoded_from(first_log):
                stamp = header_ns or log_time  # a header without a stamp: the frame is stamped at its log time
                if self._origins is not None:
                    self._origins.add(Origin(stamp, log_time, header_ns, frame_id))
                if self.pace > 0:
                    if wall0 is None or log0 is None:
                        wall0, log0 = time.monotonic(), log_time
                    else:
                        delay = (log_time - log0) / 1e9 / self.pace - (time.monotonic() - wall0)
                        if delay > 0:
                            time.sleep(delay)
                yield Frame(data, stamp / 1e9, index, self.name, frame_id=frame_id, stamp_ns=stamp)
                index += 1
        except DecodeError as exc:
            raise self.error(f"{self.topic_info.name}: message {index}: {exc}") from None

    def close(self) -> None:
        self.recording.close()
