"""A real ROS 1 system on loopback for the live tests: Debian's ``rosmaster`` and rospy nodes as child processes.

The project's venv does not see Debian's ROS 1 (it is installed for the system Python ``/usr/bin/python3``), so
every rospy node of a test is a child process of that interpreter, talking to objrec over 127.0.0.1 only.

Use (the project's tests import helpers as ``tests.<path>``)::

    from tests.ros.live.ros1_env import RospyNode, ros1_master, skip_without_ros1  # noqa: F401 (fixture)

    def test_something(ros1_master, tmp_path):
        node = RospyNode.start(PUBLISHER_SCRIPT, ros1_master, tmp_path, args=["/camera/image"])
        try:
            assert node.wait_for("ready", timeout=60) is not None
            ...
        finally:
            node.stop()

The ``ros1_master`` fixture skips the test (with the apt-get line) where ROS 1 is absent; call
:func:`skip_without_ros1` first in tests that need rospy but no master (e.g. ``rosbag`` reading a file).
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import queue
import signal
import socket
import subprocess
import threading
import time
import xmlrpc.client
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import pytest

log = logging.getLogger(__name__)

#: Debian's ROS 1 lives in the system Python, not in the venv.
SYSTEM_PYTHON = "/usr/bin/python3"
#: Debian's master (python3-rosmaster).
ROSMASTER = "/usr/bin/rosmaster"
#: What a machine without ROS 1 lacks, said in every skip.
INSTALL_HINT = ("Debian's ROS 1 is not installed: apt-get install python3-rospy python3-rosmaster python3-rosbag "
                "python3-rostopic python3-sensor-msgs python3-geometry-msgs python3-nav-msgs "
                "python3-move-base-msgs python3-actionlib-msgs python3-std-msgs")
#: Generous hang guard for a master or node to come up on a loaded 2-core machine (not a timing assertion).
STARTUP_DEADLINE = 90.0
#: How long one XML-RPC probe of a starting master may take.
_PROBE_TIMEOUT = 2.0


@functools.cache
def ros1_missing() -> str | None:
    """Why ROS 1 cannot run here (a skip reason), or None when ``rosmaster`` and the system's rospy are present."""
    if not Path(ROSMASTER).is_file() or not Path(SYSTEM_PYTHON).is_file():
        return f"{INSTALL_HINT} ({ROSMASTER} or {SYSTEM_PYTHON} not found)"
    probe = "import rospy, rosbag, rosmaster, sensor_msgs.msg, std_msgs.msg"
    try:
        done = subprocess.run([SYSTEM_PYTHON, "-c", probe], capture_output=True, text=True, timeout=120,
                              env=_base_env(), check=False)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"{INSTALL_HINT} ({SYSTEM_PYTHON} could not import rospy: {exc})"
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["?"])[-1]
        return f"{INSTALL_HINT} ({SYSTEM_PYTHON}: {last})"
    return None


def skip_without_ros1() -> None:
    """Skip the calling test, with the apt-get line, where Debian's ROS 1 (rosmaster, rospy) is absent."""
    reason = ros1_missing()
    if reason is not None:
        pytest.skip(reason)


def free_port() -> int:
    """A TCP port on 127.0.0.1 free right now (the OS's pick)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _base_env() -> dict[str, str]:
    """The environment minus anything of the venv that would confuse the system Python."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "ROS_HOSTNAME")}
    env["PATH"] = "/usr/bin:/bin"
    return env


def ros1_env(master_uri: str, home: Path) -> dict[str, str]:
    """The environment of a ROS 1 process talking to ``master_uri`` over loopback, its logs under ``home``."""
    env = _base_env()
    env.update({"ROS_MASTER_URI": master_uri, "ROS_IP": "127.0.0.1", "ROS_HOME": str(home),
                "ROS_LOG_DIR": str(home / "log"), "PYTHONUNBUFFERED": "1"})
    return env


class Ros1Master(str):
    """A running ``rosmaster``: the value is its URI (``http://127.0.0.1:PORT/``), so it can be passed
    wherever a master URI is asked for; ``env`` is the environment for nodes of it, ``port`` its port."""

    env: dict[str, str]
    port: int
    process: subprocess.Popen[bytes]
    home: Path

    @property
    def uri(self) -> str:
        return str(self)

    def proxy(self, timeout: float = 10.0) -> xmlrpc.client.ServerProxy:
        """An XML-RPC client of the master whose calls give up after ``timeout`` s (for checks such as
        ``getSystemState``)."""
        return xmlrpc.client.ServerProxy(self.uri, transport=_TimeoutTransport(timeout))

    def system_state(self) -> list[list[list[object]]]:
        """``getSystemState``'s [publishers, subscribers, services], each ``[name, [node, ...]]``."""
        code, message, state = self.proxy().getSystemState("/objrec_tests")
        assert code == 1, message
        return state

    def nodes(self) -> set[str]:
        """Every node that publishes, subscribes or serves something now."""
        return {node for group in self.system_state() for _name, members in group for node in members}


class _TimeoutTransport(xmlrpc.client.Transport):
    """XML-RPC over HTTP whose socket has a timeout (the standard one waits forever)."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host):  # type: ignore[no-untyped-def]  # matches the base's untyped signature
        connection = super().make_connection(host)
        connection.timeout = self._timeout
        return connection


def start_master(home: Path, deadline: float = STARTUP_DEADLINE) -> Ros1Master:
    """Start ``rosmaster --core`` on a free loopback port and wait until it answers (AssertionError after
    ``deadline`` s, with its output). A port taken between choosing and binding is retried with another."""
    home.mkdir(parents=True, exist_ok=True)
    for _attempt in range(3):
        port = free_port()
        uri = f"http://127.0.0.1:{port}/"
        env = ros1_env(uri, home)
        out = (home / f"rosmaster-{port}.log").open("wb")
        process = subprocess.Popen([SYSTEM_PYTHON, ROSMASTER, "--core", "-p", str(port)], env=env,
                                   stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                                   start_new_session=True)
        out.close()
        master = Ros1Master(uri)
        master.env, master.port, master.process, master.home = env, port, process, home
        end = time.monotonic() + deadline
        while process.poll() is None and time.monotonic() < end:
            try:
                code, _message, _pid = master.proxy(_PROBE_TIMEOUT).getPid("/objrec_tests")
                if code == 1:
                    log.info("rosmaster up at %s", uri)
                    return master
            except (OSError, xmlrpc.client.Error):
                pass
            time.sleep(0.1)
        output = (home / f"rosmaster-{port}.log").read_text(errors="replace")
        stop_master(master)
        if "Address already in use" not in output:
            raise AssertionError(f"rosmaster on port {port} did not come up within {deadline:.0f} s:\n{output}")
    raise AssertionError("rosmaster found no free port in 3 attempts")


def stop_master(master: Ros1Master) -> None:
    """Stop the master and everything of its process group (it forks nothing else, but be sure)."""
    _stop_process(master.process)


def _stop_process(process: subprocess.Popen[bytes], first: signal.Signals = signal.SIGTERM) -> None:
    """Stop ``process`` and its process group: ``first``, then SIGKILL after 5 s. (For a rospy node SIGINT:
    rospy shuts down and unregisters, but swallows the KeyboardInterrupt, so the script must itself end when
    rospy is shut down: ``rospy.spin()``, ``rospy.sleep()`` or a ``while not rospy.is_shutdown()`` loop.)"""
    if process.poll() is not None:
        return
    try:
        os.killpg(process.pid, first)
    except ProcessLookupError:
        return
    try:
        process.wait(timeout=5)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=15)


@pytest.fixture
def ros1_master(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Ros1Master]:
    """A real ``rosmaster`` on 127.0.0.1 at a free port for one test (skipped where ROS 1 is absent).

    Yields a :class:`Ros1Master` (a ``str``: the URI; ``.env`` for child nodes); while it runs the test
    process's ``ROS_MASTER_URI`` is that URI and ``ROS_IP`` is 127.0.0.1, so ``ros1:`` specs with no
    ``master=`` option, and child processes such as ``objrec-detect``, find it. Killed after the test.
    """
    skip_without_ros1()
    master = start_master(tmp_path / "ros_home")
    monkeypatch.setenv("ROS_MASTER_URI", master.uri)
    monkeypatch.setenv("ROS_IP", "127.0.0.1")
    monkeypatch.delenv("ROS_HOSTNAME", raising=False)
    try:
        yield master
    finally:
        stop_master(master)


class RospyNode:
    """A rospy script run by the system Python against a master; its stdout read line by line with deadlines.

    The script is the text of a Python program (written to a file under ``workdir``) or a path. It should
    print a line (``print(..., flush=True)``) when it is ready and for what the test checks, and end when rospy
    shuts down (``rospy.spin()``, ``rospy.sleep()``: :meth:`stop` sends SIGINT); stderr goes to a file, shown
    by :meth:`diagnostics` when a wait fails.
    """

    def __init__(self, process: subprocess.Popen[bytes], stderr_path: Path) -> None:
        self.process = process
        self.stderr_path = stderr_path
        self._lines: queue.Queue[str | None] = queue.Queue()
        self._reader = threading.Thread(target=self._read, name="rospy-node-stdout", daemon=True)
        self._reader.start()

    @classmethod
    def start(cls, script: str | Path, master: Ros1Master, workdir: Path, args: Sequence[str] = (),
              env: Mapping[str, str] | None = None, name: str = "node") -> RospyNode:
        """Start ``script`` (program text, or a path to one) with ``args`` as ``/usr/bin/python3 -u``, in
        ``master``'s environment plus ``env``; ``name`` names its files under ``workdir``."""
        workdir.mkdir(parents=True, exist_ok=True)
        if isinstance(script, Path):
            path = script
        else:
            path = workdir / f"{name}.py"
            path.write_text(script, encoding="utf-8")
        child_env = dict(master.env)
        child_env.update(env or {})
        stderr_path = workdir / f"{name}.stderr"
        with stderr_path.open("wb") as err:
            process = subprocess.Popen([SYSTEM_PYTHON, "-u", str(path), *args], env=child_env, cwd=workdir,
                                       stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=err,
                                       start_new_session=True)
        return cls(process, stderr_path)

    def _read(self) -> None:
        assert self.process.stdout is not None
        for raw in self.process.stdout:
            self._lines.put(raw.decode("utf-8", "replace").rstrip("\r\n"))
        self._lines.put(None)

    def line(self, timeout: float) -> str | None:
        """The next stdout line, or None when none came within ``timeout`` s or the node's output ended."""
        try:
            return self._lines.get(timeout=timeout)
        except queue.Empty:
            return None

    def wait_for(self, prefix: str, timeout: float = STARTUP_DEADLINE) -> str | None:
        """The first stdout line starting with ``prefix`` within ``timeout`` s (skipping others), else None."""
        end = time.monotonic() + timeout
        while (left := end - time.monotonic()) > 0:
            text = self.line(left)
            if text is None:
                return None
            if text.startswith(prefix):
                return text
        return None

    def lines_until(self, count: int, timeout: float) -> list[str]:
        """Up to ``count`` stdout lines read within ``timeout`` s."""
        found: list[str] = []
        end = time.monotonic() + timeout
        while len(found) < count and (left := end - time.monotonic()) > 0:
            text = self.line(left)
            if text is None:
                break
            found.append(text)
        return found

    def diagnostics(self) -> str:
        """The node's exit code and stderr so far, for an assertion message."""
        err = self.stderr_path.read_text(errors="replace") if self.stderr_path.exists() else ""
        return f"exit code {self.process.poll()}; stderr:\n{err[-4000:]}"

    def stop(self) -> None:
        """Stop the node (SIGINT, then SIGKILL after 5 s) and its process group; idempotent. The script should
        end when rospy shuts down (``rospy.spin()``, ``rospy.sleep()``, ``while not rospy.is_shutdown()``)."""
        _stop_process(self.process, signal.SIGINT)
        self._reader.join(timeout=15)
        if self.process.stdout is not None and not self._reader.is_alive():
            self.process.stdout.close()

    def __enter__(self) -> RospyNode:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.stop()

