"""DDS confined to loopback for the ROS 2 tests: a CYCLONEDDS_URI and a domain id of the test's own.

DDS announces itself by multicast on every interface unless told otherwise; tests must never send a packet
beyond loopback. The configuration made here selects only the ``lo`` interface, turns multicast off, and
names 127.0.0.1 as the one unicast discovery peer (participant indices probed up to
``MAX_PARTICIPANTS``, which bounds how many participants one test can have on one host and domain).

When Cyclone DDS reads it: a process reads ``CYCLONEDDS_URI`` when it creates a *domain*, i.e. the first
participant of a domain id in that process (checked: a participant of a new domain id made after the
variable changed follows the new text; a further participant of a domain id already live in the process
shares the domain made earlier and its configuration). So a per-test fixture works as long as every test
uses a domain id of its own, which ``free_domain`` gives: never one used before in this process, one no
other test process holds (a lock file per domain id in the temporary folder, held for the test), and one
whose first discovery ports are free on this host (other programs may be using DDS at the same time).
Domain ids stay within 1..101 so that their ports (7400 + 250 * id + ...) stay below Linux's ephemeral
range (32768 and up), as ROS 2's documentation advises.

Use from a test module (``--import-mode=importlib``: import it by its package name, as ros1_env is, so that
every test module shares the one instance that remembers the domain ids handed out)::

    from tests.ros.live import dds_env as dds
    dds_env = dds.dds_env              # the fixture, now visible to the module's tests

    def test_x(dds_env):
        transport = Ros2Transport.open(dds_env.options)           # {"domain": "<id>"}
        child = subprocess.Popen([...], env=dds_env.env)           # CYCLONEDDS_URI and ROS_DOMAIN_ID set
"""

from __future__ import annotations

import fcntl
import os
import random
import re
import select
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import pytest

#: Participant indices probed by unicast discovery (each index is two UDP ports on 127.0.0.1).
MAX_PARTICIPANTS = 32
#: Domain ids handed out (their ports stay below the ephemeral range).
DOMAINS = range(1, 102)
_BASE_PORT, _DOMAIN_GAIN, _UNICAST_OFFSET = 7400, 250, 10

_used: set[int] = set()
_locks: dict[int, IO[str]] = {}
_LOCK_DIR = Path(tempfile.gettempdir())


def loopback_config(trace: Path | None = None) -> str:
    """The Cyclone DDS configuration (XML text, as CYCLONEDDS_URI takes it) that keeps DDS on loopback:
    interface ``lo`` only, no multicast, 127.0.0.1 the only discovery peer. ``trace``: also write Cyclone's
    configuration and discovery trace to that file (what the loopback test reads)."""
    tracing = ""
    if trace is not None:
        tracing = (f"<Tracing><Category>config,discovery</Category>"
                   f"<OutputFile>{trace}</OutputFile></Tracing>")
    return (
        '<CycloneDDS><Domain Id="any">'
        '<General><Interfaces><NetworkInterface name="lo" multicast="false"/></Interfaces>'
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
        f"<MaxAutoParticipantIndex>{MAX_PARTICIPANTS}</MaxAutoParticipantIndex>"
        '<Peers><Peer address="127.0.0.1"/></Peers></Discovery>'
        f"{tracing}</Domain></CycloneDDS>"
    )


def discovery_port(domain: int, participant_index: int = 0) -> int:
    """The unicast discovery port of a participant index in a domain (DDSI-RTPS's default port mapping)."""
    return _BASE_PORT + _DOMAIN_GAIN * domain + _UNICAST_OFFSET + 2 * participant_index


def _port_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def _claim(domain: int) -> bool:
    """Hold this host's lock file of ``domain`` until the process ends (or ``release``): test runs of other
    processes using this module then never pick the same domain at the same time."""
    handle = open(_LOCK_DIR / f"objrec-tests-dds-domain-{domain}.lock", "a+")  # noqa: SIM115 - held open
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        return False
    _locks[domain] = handle
    return True


def release(domain: int) -> None:
    """Let other processes use ``domain`` again (this process still never reuses it while others remain)."""
    handle = _locks.pop(domain, None)
    if handle is not None:
        handle.close()


def free_domain() -> int:
    """A domain id not used before in this process, claimed by no other test process on this host, and
    with its first two participants' ports free."""
    candidates = [d for d in DOMAINS if d not in _used]
    if not candidates:
        _used.clear()
        candidates = list(DOMAINS)
    random.shuffle(candidates)
    for domain in candidates:
        if not _claim(domain):
            continue
        if _port_free(discovery_port(domain, 0)) and _port_free(discovery_port(domain, 1)):
            _used.add(domain)
            return domain
        release(domain)
    raise RuntimeError("no DDS domain id in 1..101 is free on this host")


@dataclass(frozen=True)
class DdsEnv:
    """One test's DDS setting: its domain id, the loopback configuration, and the environment for children."""

    domain: int
    uri: str
    env: dict[str, str] = field(repr=False)

    @property
    def options(self) -> dict[str, str]:
        """The ``ros2:`` spec options that select this domain."""
        return {"domain": str(self.domain)}

    def child_env(self, trace: Path | None = None) -> dict[str, str]:
        """The environment for a child process; with ``trace``, its Cyclone DDS also writes its trace there."""
        env = dict(self.env)
        if trace is not None:
            env["CYCLONEDDS_URI"] = loopback_config(trace)
        return env


def make_env(domain: int | None = None) -> DdsEnv:
    """A DdsEnv for ``domain`` (default: a free one); the caller sets its variables in os.environ."""
    domain = free_domain() if domain is None else domain
    uri = loopback_config()
    env = dict(os.environ)
    env.update({"CYCLONEDDS_URI": uri, "ROS_DOMAIN_ID": str(domain),
                # What a real ROS 2 installation in a child would also honour (Humble / Jazzy spelling).
                "ROS_LOCALHOST_ONLY": "1", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    return DdsEnv(domain, uri, env)


@pytest.fixture
def dds_env(monkeypatch: pytest.MonkeyPatch) -> Iterator[DdsEnv]:
    """DDS on loopback for this test: CYCLONEDDS_URI and ROS_DOMAIN_ID set in os.environ (before any
    participant of the test's domain is made) and in ``.env`` for child processes; skipped without
    cyclonedds (the ``ros2`` extra)."""
    pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")
    setting = make_env()
    for name in ("CYCLONEDDS_URI", "ROS_DOMAIN_ID", "ROS_LOCALHOST_ONLY", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(name, setting.env[name])
    yield setting
    release(setting.domain)


#: ROS 2's generated IDL for sensor_msgs/msg/Image, written by hand in cyclonedds' Python IDL: the start of a
#: child script that stands in for a ROS 2 node (none can be installed here) and knows nothing of objrec.
ROS2_IMAGE_IDL = '''
from dataclasses import dataclass
from cyclonedds.idl import IdlStruct, types

@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: types.int32
    nanosec: types.uint32

@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str

@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: types.uint32
    width: types.uint32
    encoding: str
    is_bigendian: types.uint8
    step: types.uint32
    data: types.sequence[types.uint8]
'''


def child_line(child: subprocess.Popen, guard: float, what: str) -> str:
    """The child's next stdout line (stripped); the test fails naming ``what`` if the child ends first (with
    its stderr) or says nothing within ``guard`` seconds (a hang guard, not a timing assertion)."""
    assert child.stdout is not None and child.stderr is not None
    deadline = time.monotonic() + guard
    while time.monotonic() < deadline:
        if select.select([child.stdout], [], [], 0.1)[0]:
            line = child.stdout.readline()
            if line:
                return line.strip()
        if child.poll() is not None:
            pytest.fail(f"{what}: the child ended ({child.returncode}): {child.stderr.read()}")
    pytest.fail(f"{what}: nothing within {guard:g} s")


_HEX_ADDRESS = re.compile(r"^([0-9A-F]{8}):([0-9A-F]{4})$")


def bound_udp_addresses(pid: int) -> list[tuple[str, int]]:
    """(address, port) of every IPv4 UDP socket process ``pid`` has open, from /proc (IPv6 sockets are
    reported with address "ipv6" so a test can refuse them)."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[len("socket:["):-1])
    found: list[tuple[str, int]] = []
    for table, family in (("udp", "ipv4"), ("udp6", "ipv6")):
        for line in Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]:
            fields = line.split()
            if fields[9] not in inodes:
                continue
            if family == "ipv6":
                found.append(("ipv6", int(fields[1].rsplit(":", 1)[1], 16)))
                continue
            match = _HEX_ADDRESS.match(fields[1])
            assert match is not None, line
            address = socket.inet_ntoa(int(match.group(1), 16).to_bytes(4, "little"))
            found.append((address, int(match.group(2), 16)))
    return found
