"""What the kinds' live sources share: the spec, the transport, the first frame, the newest-wins loop.

``ros1:/camera/rgb/image_raw[,master=http://HOST:11311][,timeout=S]`` and ``ros2:/camera/color/image_raw
[,domain=N][,timeout=S]``: the topic is the value without a key; ``master`` (ROS 1; default
``ROS_MASTER_URI``) and ``domain`` (ROS 2; default ``ROS_DOMAIN_ID``) go to the transport. Opening joins the
system, finds the topic's type and waits for its first message, at most ``timeout`` seconds (default 10)
in all: a topic nobody publishes, or one whose publisher sends nothing, is one SourceError naming the spec
and what is live, before any frame is asked for. The first message is decoded then too, so a topic of a type
or encoding this kind cannot read fails at once.

After that the source is a camera: not seekable, no length, and the newest message wins. When detection is
slower than the camera the transport keeps only the latest message; the ones it replaced are counted
(:attr:`LiveSource.dropped`) and said in :meth:`LiveSource.run_summary`. Waiting for the next frame has no
deadline (a robot's camera may pause) but is done in slices that check the run's stop event
(:meth:`watch_stop`) and :meth:`close`, so Ctrl-C and SIGTERM end it; a quiet topic is logged every
:data:`QUIET_WARNING` seconds. A publisher that goes away and comes back is picked up by the transport.

The kinds subclass :class:`LiveSource` (``objrec2d.live_source``, ``objrec3d.live_source``): they say which
message types they read and turn a message into their frame data; the registry knows them from light
declarations (``objrec2d.live_declaration``), so a run on files never imports this package.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from objrec_core import Float, Frame, FrameSource, Int, SourceError, SourceSpec, Str
from objrec_core.registry import UnknownModuleError
from strictio.shown import printable

from ..bags import header_frame_id, header_stamp_ns
from ..decode import DecodeError
from ..msgdefs import standard_typestore
from . import TRANSPORTS, open_transport
from .transport import LiveError, LiveMessage, Subscription, Transport

log = logging.getLogger(__name__)

#: Seconds a wait for the next frame lasts before it checks the stop event and close() again.
WAIT_SLICE = 0.2
#: Seconds without a frame after which a warning names the quiet topic (and again after as many more).
QUIET_WARNING = 5.0
#: The transport options each known scheme takes; another scheme's option is refused naming it.
TRANSPORT_OPTIONS: dict[str, tuple[str, ...]] = {"ros1": ("master",), "ros2": ("domain",)}
#: How each form is written, for messages.
FORMS = {"ros1": "ros1:/TOPIC[,master=http://HOST:11311][,timeout=S]",
         "ros2": "ros2:/TOPIC[,domain=N][,timeout=S]"}


@dataclass(frozen=True)
class LiveSpec:
    """A live spec taken apart: the scheme (transport), the topic (absolute), the transport's options as
    texts (``master``, ``domain``: only those given) and the seconds to wait for a first message."""

    text: str
    scheme: str
    topic: str
    transport_options: Mapping[str, str]
    timeout: float


def live_spec(spec: SourceSpec, values: Mapping[str, Any], topic_needed: bool = True) -> LiveSpec:
    """Check a parsed spec's typed options (``LiveSource.typed_options``) against its scheme: a topic is given
    (unless ``topic_needed`` is false, as for listing topics), ``master`` only for ros1, ``domain`` only
    for ros2. SourceError naming the spec otherwise."""
    scheme = spec.scheme or ""
    given = {key: values.get(key) for key in ("master", "domain")}
    given = {key: value for key, value in given.items() if value not in (None, "")}
    allowed = TRANSPORT_OPTIONS.get(scheme)
    for key in given:
        if allowed is not None and key not in allowed:
            owner = next(s for s, keys in TRANSPORT_OPTIONS.items() if key in keys)
            raise SourceError(f"{spec.text}: option {key} belongs to {owner}: topics; {scheme}: takes "
                              f"{FORMS.get(scheme, scheme)}")
    topic = str(values.get("topic") or "").strip()
    if not topic and topic_needed:
        raise SourceError(f"{spec.text}: no topic given ({FORMS.get(scheme, scheme + ':/TOPIC')})")
    if topic and not topic.startswith("/"):
        topic = f"/{topic}"  # a relative name resolves in the global namespace, as a node without one does
    return LiveSpec(spec.text, scheme, topic, {key: str(value) for key, value in given.items()},
                    float(values.get("timeout") or 0.0))


def join(spec: LiveSpec, node_name: str = "objrec") -> Transport:
    """The transport a live spec names, joined; one SourceError line when it cannot be (an extra missing,
    a master that does not answer)."""
    try:
        TRANSPORTS.get(spec.scheme)
    except (LookupError, UnknownModuleError) as exc:
        raise SourceError(f"{spec.text}: {exc}") from None
    try:
        return open_transport(spec.scheme, spec.transport_options, node_name)
    except LiveError as exc:
        raise SourceError(f"{spec.text}: {exc}") from None
    except ImportError as exc:  # a transport that imports its library late
        raise SourceError(f"{spec.text}: {spec.scheme} cannot be used: {exc}") from None


def deserialize(transport: Transport, typestore: Any, message: LiveMessage) -> Any:
    """A live message's bytes as a rosbags message of its type (ROS 1 or CDR by the transport)."""
    try:
        if transport.ros_version == 1:
            return typestore.deserialize_ros1(message.raw, message.msgtype)
        return typestore.deserialize_cdr(message.raw, message.msgtype)
    except Exception as exc:  # rosbags raises struct errors, IndexError, its own errors on short or bad bytes
        raise DecodeError(f"a {message.msgtype} message of {len(message.raw)} bytes cannot be read: "
                          f"{type(exc).__name__}: {exc}") from None


class Deadline:
    """Seconds left until a moment (for opening, which has one timeout for every wait it makes)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self.end = time.monotonic() + seconds

    def left(self) -> float:
        return max(0.0, self.end - time.monotonic())


class LiveSource(FrameSource):
    """Frames from a live topic of a running ROS 1 or ROS 2 system; see the module docstring.

    A kind's subclass sets ``kind``, ``readable`` (message types, rosbags' form) and ``summary``, and
    implements :meth:`decode` (and :meth:`prepare` when a topic needs others beside it). ``received`` and
    ``dropped`` count messages of the main topic; ``frames`` those handed out.
    """

    schemes = ("ros1", "ros2")
    options = {  # noqa: RUF012 - declarations, never mutated
        "topic": Str("", "the topic, e.g. /camera/rgb/image_raw"),
        "master": Str("", "ros1: the master's URI (default: ROS_MASTER_URI, else http://localhost:11311)"),
        "domain": Int(None, "ros2: the DDS domain id (default: ROS_DOMAIN_ID, else 0)", min=0, max=232,
                      optional=True),
        "timeout": Float(10.0, "seconds to wait for the topic and its first message", min=0.0, min_open=True,
                         max=86400.0),
    }
    positional = ("topic",)
    #: The message types this kind reads from a topic (rosbags' form), for checks and messages.
    readable: ClassVar[tuple[str, ...]] = ()
    #: What this kind calls them, for messages ("sensor_msgs/Image or sensor_msgs/CompressedImage").
    readable_text: ClassVar[str] = ""

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> LiveSource:
        return cls(live_spec(spec, options), **cls.extra_options(spec, options))

    @classmethod
    def extra_options(cls, spec: SourceSpec, options: dict[str, Any]) -> dict[str, Any]:
        """A kind's own options for its constructor (the 3D source's ``info`` and ``color``)."""
        return {}

    def __init__(self, spec: LiveSpec, node_name: str = "objrec") -> None:
        self.spec = spec
        self.name = spec.text
        self.topic = spec.topic
        self.msgtype = ""
        self.frames = 0
        self.skipped = 0
        self._stop: threading.Event | None = None
        self._closed = threading.Event()
        self._first: Frame | None = None
        self._subscription: Subscription | None = None
        self.transport = join(spec, node_name)
        try:
            self.typestore = standard_typestore(self.transport.ros_version)
            deadline = Deadline(spec.timeout)
            self._first = self._open(deadline)
        except BaseException:
            self.transport.close()
            raise

    # -- opening --------------------------------------------------------------------------------------
    def error(self, message: str) -> SourceError:
        return SourceError(f"{self.name}: {message}")

    def subscribe(self, topic: str, deadline: Deadline, readable: tuple[str, ...], what: str
                  ) -> tuple[Subscription, str]:
        """Subscribe to ``topic`` and learn its type within the deadline; SourceError when nobody publishes
        it in time or it holds another type than ``readable``."""
        try:
            subscription = self.transport.subscribe(topic)
        except LiveError as exc:
            raise self.error(str(exc)) from None
        try:
            msgtype = subscription.wait_type(round(deadline.left(), 2))  # rounded: the transport's line shows it
        except LiveError as exc:
            subscription.close()
            raise self.error(f"no {what}: {exc}") from None
        if msgtype not in readable:
            subscription.close()
            raise self.error(f"topic {topic} holds {msgtype}, which a {self.kind} live source cannot read as {what}")
        return subscription, msgtype

    def first_message(self, subscription: Subscription, deadline: Deadline, what: str) -> Any:
        """The first message of a subscription, deserialized, within the deadline."""
        live = subscription.next(deadline.left())
        if live is None:
            raise self.error(f"{subscription.topic} is published but no message came within "
                             f"{deadline.seconds:g} s ({what}; is its publisher sending?)")
        return self.read(live)

    def read(self, live: LiveMessage) -> Any:
        try:
            return deserialize(self.transport, self.typestore, live)
        except DecodeError as exc:
            raise self.error(f"{live.topic}: {exc}") from None

    def _open(self, deadline: Deadline) -> Frame:
        self._subscription, self.msgtype = self.subscribe(self.topic, deadline, self.readable,
                                                          self.readable_text or "frames")
        live = self._subscription.next(deadline.left())
        if live is None:
            raise self.error(f"{self.topic} is published ({self.msgtype}) but no message came within "
                             f"{deadline.seconds:g} s (is its publisher sending?)")
        message = self.read(live)
        self.prepare(message, deadline)
        try:
            return self._frame(live, message)
        except DecodeError as exc:
            raise self.error(f"{self.topic}: first message: {exc}") from None

    def prepare(self, first: Any, deadline: Deadline) -> None:
        """Check the first message and subscribe to what goes with it (a depth topic's CameraInfo), within
        the deadline; SourceError saying what is missing. Nothing to do by default."""

    @classmethod
    def usage(cls) -> str:
        return " | ".join(FORMS.get(s, f"{s}:/TOPIC") for s in cls.schemes)

    # -- the frames ---------------------------------------------------------------------------------------
    def decode(self, message: Any) -> Any:
        """A message of ``self.msgtype`` as this kind's frame data; DecodeError when it cannot be."""
        raise NotImplementedError

    def _frame(self, live: LiveMessage, message: Any) -> Frame:
        data = self.decode(message)
        stamp = header_stamp_ns(message, live.received_ns)
        frame = Frame(data, stamp / 1e9, self.frames, self.name, frame_id=header_frame_id(message), stamp_ns=stamp)
        self.frames += 1
        return frame

    def watch_stop(self, stop: threading.Event) -> None:
        self._stop = stop

    def _stopped(self) -> bool:
        return self._closed.is_set() or (self._stop is not None and self._stop.is_set())

    def __iter__(self) -> Iterator[Frame]:
        if self._first is not None:
            first, self._first = self._first, None
            yield first
        subscription = self._subscription
        if subscription is None:
            return
        quiet_since = time.monotonic()
        warn_at = QUIET_WARNING
        while not self._stopped():
            try:
                live = subscription.next(WAIT_SLICE)
            except LiveError as exc:  # the transport broke under the subscription (or was closed meanwhile)
                if self._stopped():
                    return
                raise self.error(str(exc)) from None
            if live is None:
                quiet = time.monotonic() - quiet_since
                if quiet >= warn_at and not self._stopped():
                    log.warning("%s: no message on %s for %.0f s (is its publisher still running?)",
                                self.name, self.topic, quiet)
                    warn_at += QUIET_WARNING
                continue
            quiet_since, warn_at = time.monotonic(), QUIET_WARNING
            frame = self.next_frame(live)
            if frame is not None:
                yield frame

    def next_frame(self, live: LiveMessage) -> Frame | None:
        """The frame of a message, or None (logged, counted in ``skipped``) for one that cannot be read: a
        live stream goes on past one bad message, where a recording would stop."""
        try:
            return self._frame(live, deserialize(self.transport, self.typestore, live))
        except DecodeError as exc:
            self.skipped += 1
            log.warning("%s: message skipped: %s", self.name, printable(str(exc), limit=300))
            return None

    # -- what it saw ---------------------------------------------------------------------------------------
    @property
    def received(self) -> int:
        """Messages of the topic that arrived (handed out, dropped or skipped)."""
        return self._subscription.received if self._subscription is not None else 0

    @property
    def dropped(self) -> int:
        """Messages replaced by a newer one before they were taken: frames the pipeline was too slow for."""
        return self._subscription.dropped if self._subscription is not None else 0

    def run_summary(self) -> str:
        line = f"{self.name}: {self.received} messages received, {self.dropped} dropped (newest wins)"
        return line + (f", {self.skipped} unreadable" if self.skipped else "")

    def close(self) -> None:
        """Leave the system (idempotent); a wait in progress in another thread ends within a slice."""
        self._closed.set()
        self.transport.close()
