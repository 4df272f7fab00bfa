"""Run a command and write its own peak memory (kB) and CPU time (s) to a file: ``python peak_memory.py REPORT CMD
[ARG...]`` writes ``KB SECONDS`` (one line) to REPORT. ``--file-size-limit BYTES`` before REPORT simulates a
full disk for the command: RLIMIT_FSIZE set and SIGXFSZ ignored in it, so its writes past BYTES fail with EFBIG.
Set here, in this single-threaded process's fork, rather than in a ``preexec_fn`` of the test process: Python
code run between fork and exec in a process with threads (rerun-sdk starts some at import) can deadlock.

A test that measures a command's memory cannot use ``os.wait4`` on a child it forked itself: on Linux the
child's ``ru_maxrss`` starts from the high-water mark of the test process it was forked from (copied at
``exec``), so after a test run has loaded Qt or Open3D every child seems to use 500 MB. This small process is
forked from the test and forks the command in turn: the command's own peak starts from this process's few
megabytes. The CPU time is user + system time of the command and of every child it waited for, from the same
``wait4``: tests bound that, never wall-clock time, which a busy machine stretches. Signals it gets are
passed on; it exits as the command did (the same code, or the same signal).
"""

from __future__ import annotations

import os
import resource
import signal
import sys


def _die_with_parent() -> None:
    """Linux: the command is killed when this process is (a test's timeout kill reaches the command too)."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def main() -> None:
    args = sys.argv[1:]
    file_size_limit = None
    if args[:1] == ["--file-size-limit"]:
        file_size_limit, args = int(args[1]), args[2:]
    report, argv = args[0], args[1:]
    pid = os.fork()
    if pid == 0:
        _die_with_parent()
        if file_size_limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size_limit, file_size_limit))
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        signal.setitimer(signal.ITIMER_REAL, 0)  # a test runner's alarm is not the command's
        signal.pthread_sigmask(signal.SIG_SETMASK, set())
        try:
            os.execvp(argv[0], argv)
        except OSError as exc:
            os.write(2, f"peak_memory: cannot run {argv[0]}: {exc.strerror}\n".encode())
        os._exit(127)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT):
        signal.signal(sig, lambda number, _frame: os.kill(pid, number))
    while True:
        try:
            _, status, usage = os.wait4(pid, 0)
            break
        except ChildProcessError:
            sys.exit(1)
        except InterruptedError:
            continue
    with open(report, "w", encoding="ascii") as stream:
        stream.write(f"{usage.ru_maxrss} {usage.ru_utime + usage.ru_stime:.3f}\n")
    code = os.waitstatus_to_exitcode(status)
    if code < 0:  # ended by a signal: end the same way
        signal.signal(-code, signal.SIG_DFL)
        os.kill(os.getpid(), -code)
    sys.exit(code)


if __name__ == "__main__":
    main()
