"""The ROS 1 master's XML-RPC API as a client: register and unregister, look up, list what is published.

Where the master is: the ``master`` option, else ``ROS_MASTER_URI``, else ``http://localhost:11311`` (what
roscore listens on). Every call has a deadline; a master that does not answer is one LiveError line naming
its URI and what to check.
"""

from __future__ import annotations

import logging
import os
import xmlrpc.client
from collections.abc import Mapping
from typing import Any
from urllib.parse import urlsplit

from strictio.shown import printable

from ..transport import LiveError
from .rpc import RpcFailure, call

log = logging.getLogger(__name__)

DEFAULT_MASTER_URI = "http://localhost:11311"
#: How long one call to the master may take (it answers in milliseconds when it is there).
MASTER_TIMEOUT = 5.0


def master_uri(options: Mapping[str, str]) -> str:
    """The master's URI from a spec's ``master`` option, ``ROS_MASTER_URI`` or the default; LiveError for
    one that is not ``http://HOST:PORT``."""
    uri = (options.get("master") or os.environ.get("ROS_MASTER_URI") or DEFAULT_MASTER_URI).strip()
    origin = "option master" if options.get("master") else \
        "ROS_MASTER_URI" if os.environ.get("ROS_MASTER_URI") else "default"
    try:
        parts = urlsplit(uri)
        port = parts.port
    except ValueError:
        parts, port = None, None
    if parts is None or parts.scheme != "http" or not parts.hostname or port is None:
        raise LiveError(f"ROS master URI '{printable(uri, 120)}' ({origin}) is not of the form http://HOST:PORT")
    return uri if uri.endswith("/") else uri + "/"


class Master:
    """The master at ``uri``, called as node ``caller_id``."""

    def __init__(self, uri: str, caller_id: str, timeout: float = MASTER_TIMEOUT) -> None:
        self.uri = uri
        self.caller_id = caller_id
        self.timeout = timeout

    @property
    def hostname(self) -> str:
        return urlsplit(self.uri).hostname or "localhost"

    def _call(self, method: str, *args: Any) -> Any:
        try:
            return call(self.uri, method, self.caller_id, *args, timeout=self.timeout)
        except RpcFailure as failure:
            raise LiveError(f"ROS master at {self.uri}: {method} failed: {failure.status_message}") from None
        except (OSError, xmlrpc.client.Error) as exc:
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc) or type(exc).__name__
            raise LiveError(f"ROS master at {self.uri} does not answer ({reason}): is roscore running there, is "
                            "ROS_MASTER_URI (or master=) right, can this host reach it (ROS_IP/ROS_HOSTNAME)?"
                            ) from None

    def get_uri(self) -> str:
        """The master's own idea of its URI (a cheap check that it answers)."""
        return str(self._call("getUri"))

    def register_publisher(self, topic: str, ros1_type: str, caller_api: str) -> list[str]:
        """Announce a publisher; the slave URIs of the topic's subscribers now."""
        return list(self._call("registerPublisher", topic, ros1_type, caller_api))

    def unregister_publisher(self, topic: str, caller_api: str) -> int:
        return int(self._call("unregisterPublisher", topic, caller_api))

    def register_subscriber(self, topic: str, ros1_type: str, caller_api: str) -> list[str]:
        """Announce a subscriber; the slave URIs of the topic's publishers now."""
        return list(self._call("registerSubscriber", topic, ros1_type, caller_api))

    def unregister_subscriber(self, topic: str, caller_api: str) -> int:
        return int(self._call("unregisterSubscriber", topic, caller_api))

    def lookup_node(self, node_name: str) -> str:
        return str(self._call("lookupNode", node_name))

    def published_topics(self) -> list[tuple[str, str]]:
        """(topic, ROS 1 type) of every topic with a publisher now."""
        return [(str(name), str(kind)) for name, kind in self._call("getPublishedTopics", "")]

    def topic_types(self) -> list[tuple[str, str]]:
        """(topic, ROS 1 type) of every topic the master knows, published or only subscribed."""
        return [(str(name), str(kind)) for name, kind in self._call("getTopicTypes")]

    def system_state(self) -> list[list[list[Any]]]:
        """[publishers, subscribers, services], each a list of [name, [node, ...]]."""
        return list(self._call("getSystemState"))
