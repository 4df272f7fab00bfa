"""The node's XML-RPC server (ROS 1's Slave API), so the master and other nodes can reach this node.

The master tells a subscriber of new publishers with ``publisherUpdate``; a subscriber asks a publisher for
a TCPROS port with ``requestTopic``; tools (``rosnode info``) ask ``getBusInfo``, ``getPid``. It runs in a
daemon thread, bound to the address this node advertises (see :func:`advertised_host`) on a free port.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
from http import HTTPStatus
from socketserver import ThreadingMixIn
from typing import Any, Protocol
from xmlrpc.server import SimpleXMLRPCRequestHandler, SimpleXMLRPCServer

log = logging.getLogger(__name__)

#: The largest XML-RPC request taken (a publisherUpdate with hundreds of publishers is a few kilobytes).
MAX_REQUEST_BYTES = 1024 * 1024
#: How long one peer may take over its request.
REQUEST_TIMEOUT = 10.0
_LOOPBACK = ("localhost", "127.0.0.1", "::1")


def advertised_host(master_host: str) -> str:
    """The address other nodes reach this one at: ``ROS_IP``, else ``ROS_HOSTNAME``, else 127.0.0.1 when the
    master is on loopback, else this host's address on the route to the master (found by a UDP socket's
    ``connect``, which sends no packet)."""
    for variable in ("ROS_IP", "ROS_HOSTNAME"):
        if value := os.environ.get(variable, "").strip():
            return value
    if master_host in _LOOPBACK or master_host.startswith("127."):
        return "127.0.0.1"
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect((master_host, 11311))
            return str(probe.getsockname()[0])
    except OSError:
        log.warning("no route to the ROS master host %s; advertising 127.0.0.1 (set ROS_IP)", master_host)
        return "127.0.0.1"


class NodeHooks(Protocol):
    """What the slave asks of its node (the transport)."""

    caller_id: str
    master_uri: str

    def subscriptions(self) -> list[list[str]]: ...

    def publications(self) -> list[list[str]]: ...

    def publisher_update(self, topic: str, publishers: list[str]) -> None: ...

    def request_topic(self, topic: str, protocols: list[Any]) -> list[Any]: ...

    def bus_stats(self) -> list[Any]: ...

    def bus_info(self) -> list[Any]: ...


class _Handler(SimpleXMLRPCRequestHandler):
    """Requests with a timeout and a size bound, and no access log on stderr."""

    timeout = REQUEST_TIMEOUT

    def do_POST(self) -> None:  # noqa: N802 - the standard library's name
        length = self.headers.get("content-length", "")
        if not length.strip().isdigit() or int(length) > MAX_REQUEST_BYTES:
            self.send_error(HTTPStatus.REQUEST_ENTITY_TOO_LARGE if length.strip().isdigit()
                            else HTTPStatus.LENGTH_REQUIRED)
            return
        super().do_POST()

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("slave %s: " + format, self.address_string(), *args)


class _Server(ThreadingMixIn, SimpleXMLRPCServer):
    daemon_threads = True


class _SlaveApi:
    """The Slave API's methods, as XML-RPC calls them; each answers [code, statusMessage, value]."""

    def __init__(self, node: NodeHooks) -> None:
        self._node = node

    def getBusStats(self, _caller_id: str) -> list[Any]:  # noqa: N802 - ROS names
        return [1, "bus stats", self._node.bus_stats()]

    def getBusInfo(self, _caller_id: str) -> list[Any]:  # noqa: N802
        return [1, "bus info", self._node.bus_info()]

    def getMasterUri(self, _caller_id: str) -> list[Any]:  # noqa: N802
        return [1, "master", self._node.master_uri]

    def shutdown(self, caller_id: str, message: str = "") -> list[Any]:
        # The application owns this node's lifetime (it has frames to finish and files to close): a request
        # from outside (``rosnode kill``) is logged for the user, not obeyed half-way through a run.
        log.warning("ROS node %s was asked to shut down by %s (%s); stop the program to leave", self._node.caller_id,
                    caller_id, message)
        return [1, "shutdown request logged", 0]

    def getPid(self, _caller_id: str) -> list[Any]:  # noqa: N802
        return [1, "pid", os.getpid()]

    def getSubscriptions(self, _caller_id: str) -> list[Any]:  # noqa: N802
        return [1, "subscriptions", self._node.subscriptions()]

    def getPublications(self, _caller_id: str) -> list[Any]:  # noqa: N802
        return [1, "publications", self._node.publications()]

    def paramUpdate(self, _caller_id: str, _key: str, _value: Any) -> list[Any]:  # noqa: N802
        return [1, "no parameters subscribed", 0]

    def publisherUpdate(self, _caller_id: str, topic: str, publishers: list[str]) -> list[Any]:  # noqa: N802
        self._node.publisher_update(str(topic), [str(uri) for uri in publishers])
        return [1, "publishers updated", 0]

    def requestTopic(self, _caller_id: str, topic: str, protocols: list[Any]) -> list[Any]:  # noqa: N802
        return self._node.request_topic(str(topic), list(protocols))


class Slave:
    """The running XML-RPC server of ``node`` at ``host`` (a free port); :attr:`uri` is what the master is told."""

    def __init__(self, node: NodeHooks, host: str) -> None:
        self._server = _Server((host, 0), requestHandler=_Handler, logRequests=False, allow_none=False,
                               bind_and_activate=True)
        self._server.register_instance(_SlaveApi(node))
        self._server.register_introspection_functions()
        port = self._server.server_address[1]
        self.uri = f"http://{host}:{port}/"
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.2},
                                        name=f"ros1-slave{node.caller_id}", daemon=True)
        self._thread.start()
        log.debug("ROS 1 slave of %s at %s", node.caller_id, self.uri)

    def close(self) -> None:
        """Stop serving and release the port (idempotent)."""
        if self._thread.is_alive():
            self._server.shutdown()
            self._thread.join(timeout=5)
        self._server.server_close()
