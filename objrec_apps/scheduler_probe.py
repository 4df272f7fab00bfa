"""Before objrec-batch hands its sources to ``--scheduler ADDRESS``: is a Dask scheduler there, answering, and
the user's own?

Dask's client waits long and says little where the address is wrong: an unreachable host took
10.9 s to say so, a server that accepts and never answers hung past a minute, one that speaks another
protocol ended in "Unable to allocate 3.07 EiB" (its first bytes read as a frame length) and a traceback. A
plain socket answers each in at most the deadline: the connection (refused at once, or no answer), then the
first bytes a scheduler sends of itself on every new connection (its handshake: an 8-byte length, then a
count of frames), read with the deadline and judged before anything is allocated for them.

On this machine the listening socket also has an owner (``/proc/net/tcp``): a scheduler of another user on
the port (the documented example's 8786, already taken) is refused, rather than joined silently.
"""

from __future__ import annotations

import ipaddress
import os
import pwd
import socket
import struct
from pathlib import Path

#: The deadline of the connection and of the scheduler's first bytes, seconds (--scheduler-timeout).
DEFAULT_TIMEOUT = 5.0
#: A handshake is a few hundred bytes: a length past this is another protocol's bytes read as a length.
_MAX_HANDSHAKE = 1 << 20
_MAX_FRAMES = 64


class SchedulerUnusable(Exception):
    """The address has no usable scheduler of this user; the message says what was found there."""


def probe(address: str, scheme: str, location: str, timeout: float = DEFAULT_TIMEOUT) -> None:
    """Check a ``tcp://`` or ``tls://`` scheduler address within ``timeout`` seconds (other schemes are left
    to Dask); SchedulerUnusable otherwise."""
    if scheme not in ("tcp", "tls"):
        return
    host, port = _host_port(location)
    owner = listener_owner(host, port)
    if owner is not None and owner != os.getuid():
        raise SchedulerUnusable(f"port {port} is held by a process of {_user(owner)}, not yours: another "
                                "scheduler, not the one you started (start yours on another port, "
                                "e.g. dask scheduler --port 8790)")
    try:
        connection = socket.create_connection((host, port), timeout=timeout)
    except TimeoutError:
        raise SchedulerUnusable(f"no answer within {timeout:g} s (a host that is down, or a firewall)") from None
    except OSError as exc:
        raise SchedulerUnusable(exc.strerror or str(exc)) from None
    with connection:
        if scheme == "tls":
            return  # its first bytes are TLS's own; Dask reads what follows with the same deadline
        connection.settimeout(timeout)
        first = _first_bytes(connection, 16, timeout)
    total, frames = struct.unpack("<QQ", first)
    if not 16 <= total <= _MAX_HANDSHAKE or not 1 <= frames <= _MAX_FRAMES:
        shown = first.decode("ascii", "replace")
        raise SchedulerUnusable(f"not a Dask scheduler: it answers in another protocol ({shown!r}...)")


def _first_bytes(connection: socket.socket, count: int, timeout: float) -> bytes:
    data = b""
    try:
        while len(data) < count:
            chunk = connection.recv(count - len(data))
            if not chunk:
                raise SchedulerUnusable("not a Dask scheduler: it closed the connection without a word"
                                        if not data else "not a Dask scheduler: it closed the connection")
            data += chunk
    except TimeoutError:
        raise SchedulerUnusable(f"accepted the connection but said nothing within {timeout:g} s: not a Dask "
                                "scheduler, or one that is stuck") from None
    except OSError as exc:
        raise SchedulerUnusable(exc.strerror or str(exc)) from None
    return data


def _host_port(location: str) -> tuple[str, int]:
    host, _, port = location.rpartition(":")
    host = host.strip("[]") or "127.0.0.1"
    try:
        number = int(port)
    except ValueError:
        number = 8786  # Dask's default port when none is given
    return host, number


def listener_owner(host: str, port: int) -> int | None:
    """The uid of the process listening on ``port`` of this machine (``host`` one of its own addresses), from
    ``/proc/net/tcp`` and ``tcp6``; None elsewhere, or when it cannot be told."""
    if not _is_local(host):
        return None
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(table).read_text(encoding="ascii", errors="replace").splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if len(fields) > 7 and fields[3] == "0A" and fields[1].rsplit(":", 1)[-1] == f"{port:04X}":
                try:
                    return int(fields[7])
                except ValueError:
                    return None
    return None


def _is_local(host: str) -> bool:
    if host in ("localhost", socket.gethostname()):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _user(uid: int) -> str:
    try:
        return f"user {pwd.getpwuid(uid).pw_name!r} (uid {uid})"
    except KeyError:
        return f"uid {uid}"
