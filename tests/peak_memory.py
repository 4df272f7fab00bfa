"""Run a command and write its own peak memory (kB) to a file: ``python peak_memory.py REPORT CMD [ARG...]``.

A test that measures a command's memory cannot use ``os.wait4`` on a child it forked itself: on Linux the
child's ``ru_maxrss`` starts from the high-water mark of the test process it was forked from (copied at
``exec``), so after a test run has loaded Qt or Open3D every child seems to use 500 MB. This small process is
forked from the test and forks the command in turn: the command's own peak starts from this process's few
megabytes. Signals it gets are passed on; it exits as the command did (the same code, or the same signal).
"""

from __future__ import annotations

import os
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
    report, argv = sys.argv[1], sys.argv[2:]
    pid = os.fork()
    if pid == 0:
        _die_with_parent()
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
        stream.write(f"{usage.ru_maxrss}\n")
    code = os.waitstatus_to_exitcode(status)
    if code < 0:  # ended by a signal: end the same way
        signal.signal(-code, signal.SIG_DFL)
        os.kill(os.getpid(), -code)
    sys.exit(code)


if __name__ == "__main__":
    main()
