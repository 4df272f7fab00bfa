"""One XML-RPC call of a ROS 1 API (master or another node's slave) with a deadline and its status checked.

Every ROS 1 XML-RPC method answers ``[code, statusMessage, value]`` (1 success, 0 failure, -1 error). The
standard library's client waits forever on a silent peer; here every call has a socket timeout and a fresh
connection (a ``ServerProxy`` is not safe to share between threads).
"""

from __future__ import annotations

import http.client
import xmlrpc.client
from typing import Any

#: The longest answer taken from a peer (a busy master's getSystemState is tens of kilobytes).
MAX_RESPONSE_BYTES = 16 * 1024 * 1024


class RpcFailure(Exception):
    """A peer that answered with a status other than success; ``code`` is its status (0 or -1)."""

    def __init__(self, method: str, code: int, message: str) -> None:
        super().__init__(f"{method} answered {code}: {message}")
        self.code = code
        self.status_message = message


class _TimeoutTransport(xmlrpc.client.Transport):
    """HTTP for XML-RPC whose connection has a timeout and whose answer is read with a size bound."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host: Any) -> http.client.HTTPConnection:
        connection = super().make_connection(host)
        connection.timeout = self._timeout
        return connection

    def parse_response(self, response: http.client.HTTPResponse) -> Any:
        length = response.getheader("content-length")
        too_large = f"answer over {MAX_RESPONSE_BYTES:,} bytes"
        if length is not None and length.strip().isdigit() and int(length) > MAX_RESPONSE_BYTES:
            raise xmlrpc.client.ProtocolError("", 413, too_large, {})
        parser, unmarshaller = self.getparser()
        read = 0
        while chunk := response.read(65536):
            read += len(chunk)
            if read > MAX_RESPONSE_BYTES:
                raise xmlrpc.client.ProtocolError("", 413, too_large, {})
            parser.feed(chunk)
        parser.close()
        return unmarshaller.close()


def call(uri: str, method: str, *args: Any, timeout: float) -> Any:
    """``method(*args)`` at ``uri``; its value on success. Raises :class:`RpcFailure` for a status other than
    1, ``OSError`` (timeouts included) for a peer that cannot be reached, ``xmlrpc.client.Error`` for a peer
    that does not speak XML-RPC."""
    proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout), allow_none=True)
    with proxy:
        answer = getattr(proxy, method)(*args)
    if not (isinstance(answer, list | tuple) and len(answer) == 3 and isinstance(answer[0], int)):
        raise xmlrpc.client.ResponseError(f"{method} at {uri}: not a ROS answer [code, message, value]")
    code, message, value = answer
    if code != 1:
        raise RpcFailure(method, code, str(message))
    return value
