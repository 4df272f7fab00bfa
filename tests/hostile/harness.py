"""The one child runner of the hostile-input tests: run a command as a child process and measure what
they bound: its exit code and stderr lines, its CPU time, its own peak memory, and the files it left in its working
folder.

The time bound is CPU time (user + system, of the command and every child it waited for), never wall-clock: on a
busy shared machine a command that needs 1 s of CPU may take 20 s of wall time, and "refused within 10 s" is a
promise about the work the command does, not about the machine's load. Wall-clock is only a hang
guard of minutes. The peak memory and the CPU time are the command's own, reported by tests/peak_memory.py,
which runs it (``ru_maxrss`` of a child forked straight from the test would start at the test process's own
high-water mark). A command that outgrows :data:`MEMORY_CEILING_MB` (polled from ``/proc/<pid>/status``), spends
:data:`CPU_CEILING_SECONDS` of CPU (polled from ``/proc/<pid>/stat``) or outlives the hang guard is killed with its
whole process group, so a decompression bomb that is not refused cannot take the machine with it.
Output goes through pipes rather than files, so that a file-size limit set on the child (a simulated full disk)
applies only to what the command itself writes.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
import unicodedata
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: What a case may take at most (the bounds promised for hostile input): CPU seconds of the command and peak memory.
CPU_SECONDS_LIMIT = 10.0
MEMORY_LIMIT_MB = 500.0
#: Where a child is killed outright: far above the limit, far below what would hurt a shared machine.
MEMORY_CEILING_MB = 1500.0
CPU_CEILING_SECONDS = 3 * CPU_SECONDS_LIMIT
#: Wall-clock seconds after which a child is taken as hung and killed: minutes, never a speed bound.
HANG_GUARD_SECONDS = 120.0
_TICKS = os.sysconf("SC_CLK_TCK")
_POLL_SECONDS = 0.01
_BIN = Path(sys.executable).parent


@dataclass
class Outcome:
    """What one run of a command did."""

    argv: list[str]
    exit_code: int | None  # None when it was killed
    stdout: str
    stderr: str
    seconds: float  # wall-clock, shown to a reader, never bounded
    max_rss_mb: float
    files_written: list[str] = field(default_factory=list)  # new or changed, relative to the working folder
    killed: str = ""  # "", "hang", "cpu" or "memory"
    cpu_seconds: float = 0.0  # user + system time of the command and the children it waited for

    @property
    def lines(self) -> list[str]:
        """The stderr lines."""
        return self.stderr.splitlines()

    def completed(self) -> subprocess.CompletedProcess[str]:
        """The run as ``subprocess.run`` would have given it (``returncode`` None when it was killed)."""
        return subprocess.CompletedProcess(self.argv, self.exit_code, self.stdout, self.stderr)  # type: ignore[arg-type]

    def describe(self) -> str:
        """Everything a failing assertion should show, in a few lines."""
        stderr = self.stderr if len(self.stderr) < 1500 else self.stderr[:700] + "\n...\n" + self.stderr[-700:]
        killed = f" (killed: {self.killed})" if self.killed else ""
        return (f"command: {' '.join(self.argv)}\nexit code {self.exit_code}{killed}"
                f", {self.cpu_seconds:.2f} s CPU ({self.seconds:.2f} s wall), max RSS {self.max_rss_mb:.0f} MB"
                f", files written {self.files_written}\n"
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


@dataclass(frozen=True)
class FileSizeLimit:
    """A simulated full disk: every file the command writes is limited to ``limit`` bytes (RLIMIT_FSIZE) and
    SIGXFSZ is ignored, so writes past it fail with EFBIG as they would with ENOSPC. Output through the
    harness's pipes is not limited. Given as ``preexec`` to :func:`run`, it is applied by tests/peak_memory.py
    in its own fork, not in a ``preexec_fn``: Python code between fork and exec in the test process, which
    has threads once rerun-sdk is imported, can deadlock the child before it runs anything."""

    limit: int

    def __call__(self) -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (self.limit, self.limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


def file_size_limit(limit: int | None) -> FileSizeLimit | None:
    """The ``preexec`` of a full disk at ``limit`` bytes (None: no limit)."""
    return None if limit is None else FileSizeLimit(limit)


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


def _cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system) spent so far by ``pid``, its waited-for children and its live descendants."""
    total = 0.0
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as stat:
            fields = stat.read().rsplit(")", 1)[1].split()
        total = sum(int(v) for v in fields[11:15]) / _TICKS  # utime, stime, cutime, cstime
        with open(f"/proc/{pid}/task/{pid}/children", encoding="ascii") as children:
            total += sum(_cpu_seconds(int(child)) for child in children.read().split())
    except (OSError, IndexError, ValueError):
        pass
    return total


def _reported(report: Path) -> tuple[float, float]:
    """The command's peak memory (MB) and CPU seconds as tests/peak_memory.py wrote them (0, 0 if it was killed
    first)."""
    try:
        fields = report.read_text().split()
        return int(fields[0]) / 1024.0, float(fields[1]) if len(fields) > 1 else 0.0
    except (OSError, ValueError, IndexError):
        return 0.0, 0.0
    finally:
        shutil.rmtree(report.parent, ignore_errors=True)


def _drain(stream: object, into: list[bytes]) -> threading.Thread:
    def read() -> None:
        for chunk in iter(lambda: stream.read(65536), b""):  # type: ignore[attr-defined]
            into.append(chunk)

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return thread


def _feed(stream: object, data: bytes) -> threading.Thread:
    """Write ``data`` to a child's stdin and close it, in a thread (a child that stops reading cannot block us)."""
    def write() -> None:
        try:
            stream.write(data)  # type: ignore[attr-defined]
            stream.close()  # type: ignore[attr-defined]
        except (BrokenPipeError, OSError):
            pass

    thread = threading.Thread(target=write, daemon=True)
    thread.start()
    return thread


def run(argv: Sequence[str], cwd: Path, env: dict[str, str] | None = None, timeout: float = HANG_GUARD_SECONDS,
        preexec: Callable[[], None] | None = None, stdin: bytes | None = None,
        cpu_ceiling: float = CPU_CEILING_SECONDS, watch_files: bool = True) -> Outcome:
    """Run ``argv`` (its first word a console script of the venv, or any program) in ``cwd``.

    ``timeout`` is the wall-clock hang guard (minutes: a loaded machine must not fail a test), ``cpu_ceiling`` the
    CPU seconds after which the command is killed as runaway. ``stdin`` is written to the command's standard input
    (none: /dev/null). ``preexec`` runs in the child before the command (e.g. to set RLIMIT_FSIZE). The child gets
    its own process group, so a kill at a bound takes whatever it started too. ``watch_files=False`` leaves
    ``files_written`` empty (for a ``cwd`` too big to list twice, such as the project).
    """
    cwd = Path(cwd)
    full = [command(argv[0]), *map(str, argv[1:])]
    before = _snapshot(cwd) if watch_files else {}
    out: list[bytes] = []
    err: list[bytes] = []
    start = time.monotonic()
    report = Path(tempfile.mkdtemp(prefix="peak-")) / "peak"
    wrapper = [sys.executable, str(PEAK_MEMORY)]
    if isinstance(preexec, FileSizeLimit):
        wrapper += ["--file-size-limit", str(preexec.limit)]
        preexec = None
    proc = subprocess.Popen([*wrapper, str(report), *full], cwd=cwd,
                            env=env or child_env(), stdin=subprocess.DEVNULL if stdin is None else subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=preexec,
                            start_new_session=True)
    readers = [_drain(proc.stdout, out), _drain(proc.stderr, err)]
    if stdin is not None:
        readers.append(_feed(proc.stdin, stdin))
    killed = ""
    status = 0
    while True:
        pid, status, _usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if not killed:
            if time.monotonic() - start > timeout:
                killed = "hang"
            elif _rss_mb(proc.pid) > MEMORY_CEILING_MB:
                killed = "memory"
            elif _cpu_seconds(proc.pid) > cpu_ceiling:
                killed = "cpu"
            if killed:  # not reaped yet, so the group is still the child's own
                os.killpg(proc.pid, signal.SIGKILL)
        time.sleep(_POLL_SECONDS)
    seconds = time.monotonic() - start
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
    for reader in readers:
        reader.join(5)
    for stream in (proc.stdout, proc.stderr):
        stream.close()  # type: ignore[union-attr]
    after = _snapshot(cwd) if watch_files else {}
    written = sorted(path for path, stamp in after.items() if before.get(path) != stamp)
    max_rss_mb, cpu_seconds = _reported(report)
    return Outcome(
        argv=full, exit_code=None if killed else proc.returncode,
        stdout=b"".join(out).decode("utf-8", "replace"), stderr=b"".join(err).decode("utf-8", "replace"),
        seconds=seconds, max_rss_mb=max_rss_mb, files_written=written,
        killed=killed, cpu_seconds=cpu_seconds,
    )


#: Bidirectional formatting classes: embeddings, overrides, isolates and their ends (U+202A-202E, U+2066-2069).
_BIDI_CLASSES = {"LRE", "RLE", "LRO", "RLO", "PDF", "LRI", "RLI", "FSI", "PDI"}


def raw_controls(text: str) -> list[str]:
    """Characters of ``text`` a terminal would act on: controls but tab and newline, line and paragraph
    separators, bidirectional formatting. Judged from Unicode's own data, independently of strictio.shown."""
    return [hex(ord(c)) for c in text if c not in "\t\n" and (
        unicodedata.category(c) in ("Cc", "Zl", "Zp") or unicodedata.bidirectional(c) in _BIDI_CLASSES)]


def bounded(outcome: Outcome, cpu_limit: float = CPU_SECONDS_LIMIT) -> list[str]:
    """What is wrong with a run's cost: killed, too much CPU time, too much memory, a traceback."""
    problems = []
    if outcome.killed:
        problems.append(f"killed at the {outcome.killed} bound")
    if outcome.cpu_seconds >= cpu_limit:
        problems.append(f"took {outcome.cpu_seconds:.1f} s of CPU (limit {cpu_limit:.0f} s)")
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
    """The expected refusal: exit code 2, exactly one non-empty stderr line naming ``names`` (each; a path is
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
    raw = raw_controls(outcome.stderr)
    if raw:
        problems.append(f"raw control characters on stderr: {', '.join(raw)}")
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


def the_one_error_line(result: subprocess.CompletedProcess[str]) -> str:
    """The one stderr line of a command refused with exit code 2 and no traceback."""
    lines = result.stderr.splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def char_device(tmp_path: Path) -> Path:
    """A /dev/full-like node in the test folder (root only), so that a regression cannot replace the real one."""
    import pytest

    node = tmp_path / "full"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 7))
    except (PermissionError, OSError) as exc:
        pytest.skip(f"cannot make a device node here: {exc}")
    return node
