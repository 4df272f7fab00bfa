"""Run one command as a child process and measure what issue 14 bounds: its exit code and stderr, its wall time,
its own peak memory, and the files it left in its working folder.

The peak memory is the command's own, reported by tests/peak_memory.py, which runs it (``ru_maxrss`` of a
child forked straight from the test would start at the test process's own high-water mark). A
command that outgrows :data:`MEMORY_CEILING_MB` (polled from ``/proc/<pid>/status``) or its time limit is killed
with its whole process group, so a decompression bomb that is not refused cannot take the machine with it.
Output goes through pipes rather than files, so that a file-size limit set on the child (a simulated full disk)
applies only to what the command itself writes.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: What a case may take at most (the issue's bounds).
SECONDS_LIMIT = 10.0
MEMORY_LIMIT_MB = 500.0
#: Where a child is killed outright: far above the limit, far below what would hurt a shared machine.
MEMORY_CEILING_MB = 1500.0
_POLL_SECONDS = 0.01
_BIN = Path(sys.executable).parent


@dataclass
class Outcome:
    """What one run of a command did."""

    argv: list[str]
    exit_code: int | None  # None when it was killed
    stdout: str
    stderr: str
    seconds: float
    max_rss_mb: float
    files_written: list[str] = field(default_factory=list)  # new or changed, relative to the working folder
    killed: str = ""  # "", "timeout" or "memory"

    def describe(self) -> str:
        """Everything a failing assertion should show, in a few lines."""
        stderr = self.stderr if len(self.stderr) < 1500 else self.stderr[:700] + "\n...\n" + self.stderr[-700:]
        killed = f" (killed: {self.killed})" if self.killed else ""
        return (f"command: {' '.join(self.argv)}\nexit code {self.exit_code}{killed}"
                f", {self.seconds:.2f} s, max RSS {self.max_rss_mb:.0f} MB, files written {self.files_written}\n"
                f"stderr: {stderr!r}")


def command(name: str) -> str:
    """The venv's console script ``name`` (objrec-detect, objrec-patrol, ...), else ``name`` as given."""
    path = _BIN / name
    return str(path) if path.exists() else name


def child_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    """This environment without any OBJREC_MAX_* override (the defaults are what is tested), headless Qt."""
    # PYTEST_*: the command runs as a user runs it (rerun-sdk, for one, behaves differently under pytest)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OBJREC_MAX_", "PYTEST_"))}
    env["QT_QPA_PLATFORM"] = "offscreen"
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # nothing written into the project by the child
    env.update(extra or {})
    return env


def _snapshot(folder: Path) -> dict[str, tuple[int, int, int]]:
    """Every non-folder entry under ``folder``: (inode, size, mtime); special files are listed, never opened."""
    entries: dict[str, tuple[int, int, int]] = {}
    for root, dirs, files in os.walk(folder):
        for name in files + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            path = os.path.join(root, name)
            try:
                info = os.lstat(path)
            except OSError:
                continue
            entries[os.path.relpath(path, folder)] = (info.st_ino, info.st_size, info.st_mtime_ns)
    return entries


#: The small process that runs a command and reports its own peak memory.
PEAK_MEMORY = Path(__file__).resolve().parents[1] / "peak_memory.py"


def _rss_mb(pid: int) -> float:
    """Resident memory of ``pid`` and its children (the wrapper and the command it runs)."""
    total = _own_rss_mb(pid)
    try:
        with open(f"/proc/{pid}/task/{pid}/children", encoding="ascii") as children:
            total += sum(_own_rss_mb(int(child)) for child in children.read().split())
    except OSError:
        pass
    return total


def _own_rss_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status", encoding="ascii", errors="replace") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def _reported_mb(report: Path) -> float:
    """The command's peak memory (MB) as tests/peak_memory.py wrote it (0 if it was killed first)."""
    try:
        return int(report.read_text()) / 1024.0
    except (OSError, ValueError):
        return 0.0
    finally:
        shutil.rmtree(report.parent, ignore_errors=True)


def _drain(stream: object, into: list[bytes]) -> threading.Thread:
    def read() -> None:
        for chunk in iter(lambda: stream.read(65536), b""):  # type: ignore[attr-defined]
            into.append(chunk)

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return thread


def run(argv: Sequence[str], cwd: Path, env: dict[str, str] | None = None, timeout: float = SECONDS_LIMIT,
        preexec: Callable[[], None] | None = None) -> Outcome:
    """Run ``argv`` (its first word a console script of the venv, or any program) in ``cwd``.

    ``preexec`` runs in the child before the command (e.g. to set RLIMIT_FSIZE). The child gets its own
    process group, so a kill at the timeout or the memory ceiling takes whatever it started too.
    """
    cwd = Path(cwd)
    full = [command(argv[0]), *map(str, argv[1:])]
    before = _snapshot(cwd)
    out: list[bytes] = []
    err: list[bytes] = []
    start = time.monotonic()
    report = Path(tempfile.mkdtemp(prefix="peak-")) / "peak"
    proc = subprocess.Popen([sys.executable, str(PEAK_MEMORY), str(report), *full], cwd=cwd,
                            env=env or child_env(), stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=preexec,
                            start_new_session=True)
    readers = [_drain(proc.stdout, out), _drain(proc.stderr, err)]
    killed = ""
    status = 0
    while True:
        pid, status, _usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if not killed:
            if time.monotonic() - start > timeout:
                killed = "timeout"
            elif _rss_mb(proc.pid) > MEMORY_CEILING_MB:
                killed = "memory"
            if killed:  # not reaped yet, so the group is still the child's own
                os.killpg(proc.pid, signal.SIGKILL)
        time.sleep(_POLL_SECONDS)
    seconds = time.monotonic() - start
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
    for reader in readers:
        reader.join(5)
    for stream in (proc.stdout, proc.stderr):
        stream.close()  # type: ignore[union-attr]
    after = _snapshot(cwd)
    written = sorted(path for path, stamp in after.items() if before.get(path) != stamp)
    return Outcome(
        argv=full, exit_code=None if killed else proc.returncode,
        stdout=b"".join(out).decode("utf-8", "replace"), stderr=b"".join(err).decode("utf-8", "replace"),
        seconds=seconds, max_rss_mb=_reported_mb(report), files_written=written,
        killed=killed,
    )


_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f]")


def bounded(outcome: Outcome) -> list[str]:
    """What is wrong with a run's cost: killed, too slow, too much memory."""
    problems = []
    if outcome.killed:
        problems.append(f"killed at the {outcome.killed} bound")
    if outcome.seconds >= SECONDS_LIMIT:
        problems.append(f"took {outcome.seconds:.1f} s (limit {SECONDS_LIMIT:.0f} s)")
    if outcome.max_rss_mb >= MEMORY_LIMIT_MB:
        problems.append(f"max RSS {outcome.max_rss_mb:.0f} MB (limit {MEMORY_LIMIT_MB:.0f} MB)")
    if "Traceback" in outcome.stderr:
        problems.append("a traceback on stderr")
    return problems


def outside(outcome: Outcome, outputs: Iterable[str]) -> list[str]:
    """Files written that are neither a declared output nor inside a declared output folder."""
    allowed = [Path(o) for o in outputs]
    return [p for p in outcome.files_written
            if not any(Path(p) == a or Path(p).is_relative_to(a) for a in allowed)]


def assert_refused(outcome: Outcome, names: str | Sequence[str], outputs: Iterable[str] = ()) -> None:
    """Issue 14's refusal: exit code 2, exactly one non-empty stderr line naming ``names`` (each; a path is
    matched by its basename), no traceback, no control character, within the time and memory bounds, nothing
    written but ``outputs``. Every problem is listed at once."""
    problems = bounded(outcome)
    if outcome.exit_code != 2:
        problems.append(f"exit code {outcome.exit_code}, expected 2")
    lines = outcome.stderr.splitlines()
    if len(lines) != 1 or not lines[0].strip():
        problems.append(f"{len(lines)} stderr lines, expected exactly one")
    for name in [names] if isinstance(names, str) else names:
        shown = Path(name).name if "/" in name else name
        if shown not in outcome.stderr:
            problems.append(f"stderr does not name {shown!r}")
    if _CONTROL.search(outcome.stderr):
        problems.append("a raw control character on stderr")
    stray = outside(outcome, outputs)
    if stray:
        problems.append(f"files written outside the output: {stray}")
    assert not problems, "; ".join(problems) + "\n" + outcome.describe()


def assert_succeeded(outcome: Outcome, outputs: Iterable[str] = ()) -> None:
    """Exit code 0 within the bounds, no traceback, nothing written but ``outputs``."""
    problems = bounded(outcome)
    if outcome.exit_code != 0:
        problems.append(f"exit code {outcome.exit_code}, expected 0")
    stray = outside(outcome, outputs)
    if stray:
        problems.append(f"files written outside the output: {stray}")
    assert not problems, "; ".join(problems) + "\n" + outcome.describe()


def complete_json_lines(path: Path) -> list[str]:
    """What is wrong with a JSON Lines file written before a failure: a half line, a line that is no JSON."""
    if not path.exists():
        return []
    text = path.read_text(encoding="utf-8", errors="replace")
    problems = []
    if text and not text.endswith("\n"):
        problems.append(f"{path.name} ends in a half line ({len(text)} bytes)")
    for number, line in enumerate(text.splitlines(), 1):
        try:
            json.loads(line)
        except ValueError:
            problems.append(f"{path.name} line {number} is not complete JSON")
            break
    return problems
