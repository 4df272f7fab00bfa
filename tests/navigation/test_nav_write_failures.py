"""objrec-patrol's outputs on a full disk (--events, --diagram, --render) and onto what must not be replaced.

A full disk is simulated portably: the command runs in a child with a file size limit (RLIMIT_FSIZE) and
SIGXFSZ ignored, so writes past the limit fail with EFBIG as they would with ENOSPC.
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import navigation
from navigation.events import EventLog
from strictio import OutputError
from tests.hostile import harness
from tests.hostile.harness import char_device, the_one_error_line

DATA = Path(navigation.__file__).parent / "data"
PATROL = [sys.executable, "-m", "navigation.cli", str(DATA / "b5203.txt"), "--map", str(DATA / "b5203.yaml"),
          "--laps", "1"]


def patrol_on_full_disk(args: list[str], limit: int | None) -> tuple[subprocess.CompletedProcess[str], float]:
    """objrec-patrol with every file it writes limited to ``limit`` bytes (tests/hostile/harness.py); the result
    and its CPU seconds."""
    run = harness.run([*PATROL, *args], Path.cwd(), preexec=harness.file_size_limit(limit), watch_files=False)
    return run.completed(), run.cpu_seconds




def test_events_on_a_full_disk_keep_only_whole_lines(tmp_path):
    events = tmp_path / "e.jsonl"
    result, cpu_seconds = patrol_on_full_disk(["--events", str(events)], limit=3000)
    line = the_one_error_line(result)
    text = events.read_text()
    kept = [json.loads(row) for row in text.splitlines()]
    assert line == (f"objrec-patrol: error: {events}: cannot be written: File too large; {len(kept)} whole lines "
                    "before it are kept")
    assert 0 < len(text) <= 3000 and text.endswith("\n")
    assert kept[0] == {"t": 0.0, "type": "state_enter", "state": "MONITORED_PATROL"}
    assert cpu_seconds < harness.CPU_SECONDS_LIMIT


def test_a_diagram_on_a_full_disk_is_an_error_and_the_old_one_stays(tmp_path):
    diagram = tmp_path / "machine.md"
    diagram.write_text("the diagram of the run before\n")
    result, _ = patrol_on_full_disk(["--diagram", str(diagram)], limit=200)  # the diagram needs more
    assert the_one_error_line(result) == f"objrec-patrol: error: {diagram}: cannot save: File too large"
    assert diagram.read_text() == "the diagram of the run before\n"
    assert [p.name for p in tmp_path.iterdir()] == ["machine.md"]  # no temporary left


def test_a_diagram_onto_a_device_leaves_the_device_node(tmp_path):
    device = char_device(tmp_path)
    result, _ = patrol_on_full_disk(["--diagram", str(device)], limit=None)
    assert the_one_error_line(result) == (f"objrec-patrol: error: {device}: refused as --diagram: it is a character "
                                          "device, not a regular file; nothing was written")
    assert stat.S_ISCHR(device.stat().st_mode) and device.stat().st_rdev == os.makedev(1, 7)


@pytest.mark.parametrize(("name", "message"), [
    ("run.png", "cannot save: File too large"),
    ("run.avi", r"cannot save: only \d+ of \d+ frames could be written \(a full disk or a file size limit\?\)"),
])
def test_a_render_on_a_full_disk_is_an_error_and_leaves_nothing(tmp_path, name, message):
    target = tmp_path / "pictures" / name
    target.parent.mkdir()
    result, _ = patrol_on_full_disk(["--render", str(target)], limit=20_000)
    line = the_one_error_line(result)
    assert line.startswith(f"objrec-patrol: error: {target}: ") and re.search(message, line), line
    assert list(target.parent.iterdir()) == []


def test_an_event_log_that_failed_keeps_the_run_going_in_memory(tmp_path, monkeypatch):
    log = EventLog(lambda: 1.5)
    log.open(tmp_path / "e.jsonl")
    log.emit("first")

    def full_disk(_fd: int, _data: bytes) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr("strictio.atomic.os.write", full_disk)
    with pytest.raises(OutputError, match=r"e\.jsonl: cannot be written: No space left on device; 1 whole line "
                                          "before it is kept"):
        log.emit("second")
    assert log.emit("third")["type"] == "third"  # the file is done for; the run's end does not fail on it again
    log.close()
    assert [e["type"] for e in log.events] == ["first", "second", "third"]
    assert (tmp_path / "e.jsonl").read_text() == '{"t": 1.5, "type": "first"}\n'
