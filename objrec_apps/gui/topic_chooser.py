"""Which topic of a recording to play: asked when a bag or MCAP file holds more than one.

The source spec stays the one grammar: the answer becomes ``bag:PATH,topic=NAME``. Without rosbags installed
the spec goes on unchanged and opening it says which extra to install.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from objrec_core import SourceError

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


def with_topic(spec: str, ask: Ask) -> str | None:
    """``spec`` with the topic the user chose when it names a recording of several topics; the spec itself
    when there is nothing to choose; None when the user cancelled."""
    if ":" in spec.split("/", 1)[0] and not spec.lower().startswith("bag:"):
        return spec  # another scheme (demo:, camera:)
    path = spec[4:].split(",", 1)[0] if spec.lower().startswith("bag:") else spec
    if spec.lower().startswith("bag:") and "topic=" in spec:
        return spec
    topics = recording_topics(path)
    if not topics or len(topics) < 2:
        return spec
    labels = [f"{name}   ({msgtype}, {count} messages)" for name, msgtype, count in topics]
    chosen = ask(f"{path} holds {len(topics)} topics: play which?", labels)
    if chosen is None:
        return None
    topic = topics[labels.index(chosen)][0]
    return f"bag:{path},topic={topic}"
