"""rerunio: where a Rerun recording goes, for every command that makes one (``--rerun FILE.rrd|spawn``).

A ``.rrd`` file (its missing folders made; written by :mod:`rerunio.rrd_file` under a temporary name, renamed
when the recording closes whole, removed when writing it failed, so a full disk neither hangs nor leaves a
file), or a viewer started here (or already listening) on a local port.
rerun-sdk is imported only when a recording is opened, so importing this needs no extra; every failure is a
:class:`RerunUnavailable` with one line for the user. :class:`Recorder` (:mod:`rerunio.recorder`) is the base
of every recorder: timelines, write failures noticed while recording, one close. It imports nothing of the
project but the floor (strictio), so objrec-detect and the navigation stack's objrec-patrol share it without
depending on each other.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from strictio import OutputError

from .recorder import CHECK_EVERY, Recorder
from .rrd_file import RrdFile

log = logging.getLogger(__name__)

__all__ = ["CHECK_EVERY", "INSTALL_HINT", "VIEWER_PORT", "Recorder", "RerunUnavailable", "file_of", "forget_file",
           "import_rerun", "open_stream", "spawn_viewer"]

INSTALL_HINT = "install objrec[viz] (pip install 'objrec[viz]')"
#: The port ``rerun`` listens on by default; ``spawn`` starts (or reuses) a viewer there.
VIEWER_PORT = 9876
#: How long a freshly started viewer may take to accept connections.
VIEWER_START_SECONDS = 15.0
#: How long a started viewer must keep running before recording to it.
VIEWER_SETTLE_SECONDS = 1.5


class RerunUnavailable(RuntimeError):
    """A Rerun recording cannot be made as asked: rerun-sdk is not installed, no viewer can be spawned,
    or the target is neither ``spawn`` nor a writable ``.rrd`` path. The message is one line for the user."""


def import_rerun() -> Any:
    # rerun's own log lines (a full disk as three WARN/ERROR lines) would break the commands' one-line errors:
    # the commands report write failures themselves. RUST_LOG set by the user still wins.
    os.environ.setdefault("RUST_LOG", "off")
    try:
        import rerun
    except ImportError as exc:
        raise RerunUnavailable(f"--rerun needs rerun-sdk, which is not installed: {INSTALL_HINT}") from exc
    return rerun


def _listening(port: int) -> bool:
    with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), timeout=0.5):
        return True
    return False


def _viewer_command() -> list[str]:
    """The Rerun viewer that ships with rerun-sdk (``rerun_cli``), else a ``rerun`` on PATH."""
    if importlib.util.find_spec("rerun_cli") is not None:
        return [sys.executable, "-m", "rerun_cli"]
    found = shutil.which("rerun")
    if found is None:
        raise RerunUnavailable(f"--rerun spawn: no Rerun viewer found (rerun_cli or rerun on PATH); {INSTALL_HINT}")
    return [found]


def spawn_viewer(port: int = VIEWER_PORT) -> None:
    """Start a Rerun viewer listening on ``port`` (or use the one already there).

    Started here rather than by ``rr.spawn`` because that viewer inherits stdout, where objrec-detect
    writes its JSON; this one gets the null device instead, and its stderr stays where ours goes.
    """
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise RerunUnavailable("--rerun spawn: no display to show the Rerun viewer on (DISPLAY and "
                               "WAYLAND_DISPLAY are unset); record to a file instead: --rerun out.rrd")
    if _listening(port):
        log.info("a viewer already listens on port %d; recording to it", port)
        return
    command = [*_viewer_command(), f"--port={port}", "--expect-data-soon"]
    try:
        viewer = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                  start_new_session=True)
    except OSError as exc:
        raise RerunUnavailable(f"--rerun spawn: the Rerun viewer cannot be started: {exc}") from None
    deadline = time.monotonic() + VIEWER_START_SECONDS
    while not _listening(port):
        code = viewer.poll()
        if code is not None:
            raise RerunUnavailable(f"--rerun spawn: the Rerun viewer stopped at once (exit code {code}); "
                                   "record to a file instead: --rerun out.rrd")
        if time.monotonic() > deadline:
            raise RerunUnavailable(f"--rerun spawn: the Rerun viewer did not listen on port {port} within "
                                   f"{VIEWER_START_SECONDS:g} s; record to a file instead: --rerun out.rrd")
        time.sleep(0.1)
    # The viewer listens before it opens its window, and a window that cannot open (a display that is set
    # but unreachable) ends it a moment later: see that it survives that moment.
    settled = time.monotonic() + VIEWER_SETTLE_SECONDS
    while time.monotonic() < settled:
        code = viewer.poll()
        if code is not None:
            raise RerunUnavailable(f"--rerun spawn: the Rerun viewer could not open its window (exit code {code}); "
                                   "record to a file instead: --rerun out.rrd")
        time.sleep(0.1)


def open_stream(target: str | os.PathLike[str], application_id: str, blueprint: Any = None,
                port: int = VIEWER_PORT) -> Any:
    """A ``rr.RecordingStream`` writing to ``target``: a path ending in ``.rrd`` or ``spawn``."""
    rr = import_rerun()
    text = os.fspath(target)
    if text != "spawn" and Path(text).suffix.lower() != ".rrd":
        raise RerunUnavailable(f"--rerun {text}: give a file ending in .rrd, or spawn to open the viewer")
    stream = rr.RecordingStream(application_id)
    if text == "spawn":
        spawn_viewer(port)
        try:
            stream.connect_grpc(f"rerun+http://127.0.0.1:{port}/proxy", default_blueprint=blueprint)
        except (RuntimeError, ValueError) as exc:
            raise RerunUnavailable(f"--rerun spawn: cannot connect to the Rerun viewer: {exc}") from None
        return stream
    path = Path(text).expanduser()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _FILES[id(stream)] = RrdFile(stream, path, text, blueprint)
    except OutputError as exc:
        raise RerunUnavailable(str(exc)) from None
    except (OSError, RuntimeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise RerunUnavailable(f"{text}: cannot be written: {reason}") from None
    return stream


#: The .rrd files being written, by the id of their recording stream (see :mod:`rerunio.rrd_file`).
_FILES: dict[int, RrdFile] = {}


def file_of(stream: Any) -> RrdFile | None:
    """The ``.rrd`` file ``stream`` is written into (None for a viewer's stream)."""
    return _FILES.get(id(stream))


def forget_file(stream: Any) -> None:
    """Drop the record of ``stream``'s file once it is finished or abandoned."""
    _FILES.pop(id(stream), None)


# -- geometry ---------------------------------------------------------------------------------------
