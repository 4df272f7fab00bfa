"""``objrec-detect --list-topics ros1:`` (or ``ros2:``, ``ros1:,master=URI``): the topics published now.

The same spec options as a live source (``master``, ``domain``; ``timeout`` bounds ROS 2's discovery, default
:data:`LIST_TIMEOUT` s), printed as ``--list-topics`` prints a recording's topics: an aligned table of topic
and type, then a last line saying where they were seen.
"""

from __future__ import annotations

from objrec_core import SourceError, SourceSpec

from . import TRANSPORTS
from .source import LiveSource, join, live_spec
from .transport import LiveError

#: Seconds a ROS 2 listing waits for discovery unless the spec gives ``timeout=``.
LIST_TIMEOUT = 2.0


def is_live_spec(text: str) -> bool:
    """Whether ``text`` names a live system (``ros1:...``, ``ros2:...``, an installed transport's scheme)."""
    return SourceSpec.parse(text, set(TRANSPORTS.names())).scheme is not None


def list_live_topics(text: str) -> str:
    """The table of topics live on the system ``text`` names; SourceError (one line) when it cannot be seen."""
    spec = SourceSpec.parse(text, set(TRANSPORTS.names()))
    values = LiveSource.typed_options(spec)
    target = live_spec(spec, values, topic_needed=False)
    timeout = values["timeout"] if "timeout" in spec.options else LIST_TIMEOUT
    with join(target, "objrec_list") as transport:
        try:
            topics = transport.topics(timeout)
        except LiveError as exc:
            raise SourceError(f"{text}: {exc}") from None
    rows = [("topic", "type")] + [(t.name, t.msgtype) for t in topics]
    width = max(len(name) for name, _ in rows)
    table = "\n".join(f"{name:<{width}}  {msgtype}".rstrip() for name, msgtype in rows)
    where = ", ".join(f"{key}={value}" for key, value in target.transport_options.items())
    plural = "" if len(topics) == 1 else "s"
    return f"{table}\n{target.scheme}{f' ({where})' if where else ''}: {len(topics)} topic{plural} published"
