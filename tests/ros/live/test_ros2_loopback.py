"""The DDS test setting keeps every packet on loopback: what can be proved of it, from two sides.

Cyclone DDS's own account (its trace, configuration and discovery categories) of a child process running
objrec's ros2 transport: the only interface selected is ``lo``, multicast is off, and every address it
puts in a locator, a peer list or a destination set is 127.0.0.1. The kernel's account (/proc) of the
same child's sockets: its sending socket is bound to 127.0.0.1, from which Linux routes nothing but
loopback, and its receiving sockets are wildcard-bound and receive-only. What is not proved here: that no
other code in the process opens a socket (nothing else does in these tests).

Also the premise of ``dds_env``: a process reads CYCLONEDDS_URI anew for each new domain id.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from objrec_ros.live import open_transport
from objrec_ros.live.ros2.entities import delete_entity
from objrec_ros.msgdefs import standard_typestore
from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out

dds_env = dds.dds_env  # the fixture, used by name

HANG_GUARD = 60.0

#: objrec's transport publishing until told to stop on stdin, then closing cleanly (the trace is complete).
OBJREC_PUBLISHER = '''
import select, sys, time
from objrec_ros.live import open_transport
from objrec_ros.live.ros2.entities import delete_entity
from objrec_ros.msgdefs import standard_typestore
store = standard_typestore(2)
raw = bytes(store.serialize_cdr(store.types["std_msgs/msg/String"](data="on loopback"), "std_msgs/msg/String"))
with open_transport("ros2", {}) as transport:  # the domain from ROS_DOMAIN_ID
    publisher = transport.advertise("/loopback", "std_msgs/msg/String", store)
    print("ready", flush=True)
    for _ in range(1200):
        publisher.publish(raw)
        if select.select([sys.stdin], [], [], 0.05)[0]:
            break
print("closed", flush=True)
'''

_UDP_ADDRESS = re.compile(r"udp/(\d+\.\d+\.\d+\.\d+)")
#: Trace lines that name addresses DDS did not use: its configuration echo, the host's interfaces it
#: looked at before selecting, and the multicast addresses configured but disabled.
_NOT_USED = re.compile(r"config: |: interfaces: |: SPDP MC: |: default MC: ")


def test_a_childs_dds_traffic_stays_on_loopback(dds_env, tmp_path: Path) -> None:
    trace = tmp_path / "cyclonedds.log"
    store = standard_typestore(2)
    child = subprocess.Popen([sys.executable, "-c", OBJREC_PUBLISHER], env=dds_env.child_env(trace),
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert dds.child_line(child, HANG_GUARD, "the publisher started") == "ready"
        with open_transport("ros2", dds_env.options) as objrec:
            subscription = objrec.subscribe("/loopback", "std_msgs/msg/String", store)
            message = subscription.next(HANG_GUARD)
            assert message is not None
            assert store.deserialize_cdr(message.raw, "std_msgs/msg/String").data == "on loopback"
            sockets = dds.bound_udp_addresses(child.pid)
        child.stdin.write("stop\n")
        child.stdin.flush()
        assert dds.child_line(child, HANG_GUARD, "the publisher closed") == "closed"
        child.wait(timeout=HANG_GUARD)
    finally:
        child.kill()
        child.wait(timeout=HANG_GUARD)

    # The kernel's account: one sending socket, on 127.0.0.1; the rest receive on the wildcard; no IPv6.
    addresses = [address for address, _ in sockets]
    assert addresses.count("127.0.0.1") >= 1
    assert set(addresses) <= {"127.0.0.1", "0.0.0.0"}, sockets

    # Cyclone's account.
    text = trace.read_text()
    assert "config: Domain/General/AllowMulticast/#text: false" in text
    selected = re.findall(r"selected interfaces: (\S+) \(", text)
    assert selected == ["lo"]
    assert "ownip: udp/127.0.0.1" in text
    used = [address for line in text.splitlines() if not _NOT_USED.search(line)
            for address in _UDP_ADDRESS.findall(line)]
    assert len(used) > 10  # peers, locators of the discovered participant, destination sets
    assert set(used) == {"127.0.0.1"}
    # The parent (this test) was discovered at 127.0.0.1 and nowhere else.
    discovered = re.findall(r"SPDP ST0 .* NEW .*\(data (udp/\S+) meta (udp/\S+)\)", text)
    assert discovered and all(d.startswith("udp/127.0.0.1:") and m.startswith("udp/127.0.0.1:")
                              for d, m in discovered)


def test_cyclonedds_reads_the_configuration_anew_for_each_new_domain(monkeypatch, tmp_path: Path) -> None:
    from cyclonedds.domain import DomainParticipant

    traces = []
    participants = []
    for run in range(2):
        domain = dds.free_domain()
        trace = tmp_path / f"run{run}.log"
        monkeypatch.setenv("CYCLONEDDS_URI", dds.loopback_config(trace))
        participants.append(DomainParticipant(domain))
        traces.append((trace, domain))
    for participant in participants:
        delete_entity(participant)  # the domain ends: its trace is complete and closed
    for trace, domain in traces:
        text = trace.read_text()
        assert f"rtps_init: domainid {domain} " in text
        assert "selected interfaces: lo (" in text
        dds.release(domain)
