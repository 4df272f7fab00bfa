"""Which topic to play: of a recording (asked when a bag or MCAP file holds more than one), or of a live ROS 1
or ROS 2 system (File > Open topic, listed by ``live_topic_dialog.py``).

The source spec stays the one grammar: the answer becomes ``bag:PATH,topic=NAME``, or ``ros1:/TOPIC,master=URI``
and ``ros2:/TOPIC,domain=N``. Without rosbags installed the spec goes on unchanged and opening it says which
extra to install. Nothing here imports Qt or a transport: listing live topics is the dialog's job.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from objrec_core import SourceError, source_entries
from objrec_core.source_declaration import DeclaredSource

log = logging.getLogger(__name__)

#: Asks the user to pick one of the labels (title, labels) and returns it, or None when cancelled.
Ask = Callable[[str, list[str]], str | None]


def recording_topics(path: str) -> list[tuple[str, str, int]] | None:
    """(topic, type, messages) of a recording, or None when ``path`` is no recording or rosbags is missing."""
    try:
        from objrec_ros.bags import is_recording_path, open_recording
    except ImportError:
        return None
    if not is_recording_path(path):
        return None
    try:
        with open_recording(path) as recording:
            return [(t.name, t.msgtype, t.count) for t in recording.topics()]
    except (SourceError, ImportError) as exc:
        log.info("%s: topics not listed: %s", path, exc)
        return None  # opening it as a source reports the problem in full


def with_topic(spec: str, ask: Ask, kind: str | None = None) -> str | None:
    """``spec`` with the topic the user chose when it names a recording of several topics; the spec itself
    when there is nothing to choose; None when the user cancelled. With the pipeline's data ``kind``, only
    the topics of message types its sources read are offered (an image pipeline is not offered a
    PointCloud2 topic), and the only one is taken without a question."""
    if ":" in spec.split("/", 1)[0] and not spec.lower().startswith("bag:"):
        return spec  # another scheme (demo:, camera:)
    path = spec[4:].split(",", 1)[0] if spec.lower().startswith("bag:") else spec
    if spec.lower().startswith("bag:") and "topic=" in spec:
        return spec
    topics = recording_topics(path)
    if not topics or len(topics) < 2:
        return spec
    readable = kind_msgtypes(kind)
    if readable is not None:
        topics = [topic for topic in topics if topic[1] in readable]
        if len(topics) == 1:
            return f"bag:{path},topic={topics[0][0]}"
        if not topics:
            return spec  # opening it says the recording holds no topic the pipeline reads
    labels = [f"{name}   ({msgtype}, {count} messages)" for name, msgtype, count in topics]
    chosen = ask(f"{path} holds {len(topics)} topics: play which?", labels)
    if chosen is None:
        return None
    topic = topics[labels.index(chosen)][0]
    return f"bag:{path},topic={topic}"


def kind_msgtypes(kind: str | None) -> frozenset[str] | None:
    """The message types (rosbags' form) the sources of ``kind`` read, as its live source declares them (a
    recording holds the same messages); None when not known, so every topic is offered."""
    if kind is None:
        return None
    for scheme in LIVE_SCHEMES:
        reading = live_reading(kind, scheme)
        if reading.msgtypes:
            return reading.msgtypes
    return None


#: The live transports' schemes and what the dialog calls them (the transports are plug-ins of objrec_ros).
LIVE_SCHEMES = {"ros1": "ROS 1", "ros2": "ROS 2"}
#: Where a ROS 1 master is when ROS_MASTER_URI does not say (ROS's own default).
DEFAULT_MASTER = "http://localhost:11311"


def is_live_spec(spec: str) -> bool:
    """Whether ``spec`` names a live topic (``ros1:/camera/image``, ``ros2:...``)."""
    return spec.partition(":")[0].strip().lower() in LIVE_SCHEMES and ":" in spec


def live_defaults(environ: Mapping[str, str] | None = None) -> dict[str, str]:
    """The address options a user's environment gives, as ROS's own tools read them: ``master`` from
    ROS_MASTER_URI, ``domain`` from ROS_DOMAIN_ID."""
    env = os.environ if environ is None else environ
    domain = env.get("ROS_DOMAIN_ID", "").strip()
    return {"master": env.get("ROS_MASTER_URI", "").strip() or DEFAULT_MASTER,
            "domain": domain if domain.isdigit() else "0"}


def live_spec(scheme: str, topic: str, options: Mapping[str, str]) -> str:
    """The source spec of a live topic with its address spelled out, so the name on screen (and a copy of it
    on a command line) reads the same topic again: ``ros1:/camera/image,master=http://…``."""
    key = "master" if scheme == "ros1" else "domain"
    extra = "".join(f",{k}={v}" for k, v in options.items() if k != key and v)
    return f"{scheme}:{topic},{key}={options[key]}{extra}"


@dataclass(frozen=True)
class LiveReading:
    """What the live source of a pipeline's kind reads: its message types (rosbags' form; None when not
    known, so every topic is offered) and how it says so ("images (sensor_msgs/Image or CompressedImage)")."""

    msgtypes: frozenset[str] | None
    text: str = ""


def live_reading(kind: str | None, scheme: str) -> LiveReading:
    """What the live source of ``kind`` reads on ``scheme``, from its declared ``readable`` types and
    ``readable_text`` (objrec_ros.live.source.LiveSource); a kind with no live source reads nothing."""
    if kind is None:
        return LiveReading(None)
    for entry in source_entries(kind).values():
        if scheme in entry.schemes:  # only this source's implementation is imported, not the kind's others
            source_type = entry.load() if isinstance(entry, DeclaredSource) else entry
            declared = getattr(source_type, "readable", None)
            text = str(getattr(source_type, "readable_text", "") or ", ".join(sorted(declared or ())))
            return LiveReading(frozenset(declared) if declared else None, text)
    return LiveReading(frozenset(), "no live topic")
