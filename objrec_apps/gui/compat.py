"""Work-arounds for bugs in the installed Qt bindings, each detected at run time rather than assumed.

PySide6 6.12.0 on CPython 3.11 and older drops a reference to ``None`` on every call of a Qt method that
returns nothing (``update()``, ``setText()``, ``processEvents()``...) and to ``True``/``False`` on every
signal ``emit()``. CPython 3.12 made these singletons immortal, which hides the bug there; on 3.11 they start
with a few thousand references, so after a few thousand such calls the interpreter aborts with
"deallocating None" (or "True or False"). PySide6 6.11.3 does not have the bug. Where it is detected, the
three singletons get the huge reference count 3.12 gives every immortal object, which is exactly the
guarantee those bindings were written for.
"""

from __future__ import annotations

import ctypes
import logging
import sys

log = logging.getLogger(__name__)

_PROBE_CALLS = 64
#: The references added: at a million leaking calls a second, they last about two weeks.
_EXTRA_REFERENCES = 1 << 40
_applied = False


def singleton_leaks() -> dict[str, int]:
    """References lost per call, measured: ``None`` by a void method, ``True`` by a signal's emit()."""
    from PySide6.QtCore import QObject, Signal

    class _Probe(QObject):
        ping = Signal()

    probe = _Probe()
    probe.ping.connect(lambda: None)
    lost = {}
    before = sys.getrefcount(None)
    for _ in range(_PROBE_CALLS):
        probe.setObjectName("objrec-probe")
    lost["None"] = before - sys.getrefcount(None)
    before_true, before_false = sys.getrefcount(True), sys.getrefcount(False)
    for _ in range(_PROBE_CALLS):
        probe.ping.emit()
    lost["bool"] = (before_true - sys.getrefcount(True)) + (before_false - sys.getrefcount(False))
    return {name: max(0, round(count / _PROBE_CALLS)) for name, count in lost.items()}


def guard_none_refcount() -> bool:
    """Make None, True and False immortal where the bindings leak their references; True if guarded."""
    global _applied
    if _applied:
        return True
    if sys.implementation.name != "cpython" or sys.version_info >= (3, 12):
        return False
    leaks = singleton_leaks()
    if not any(leaks.values()):
        return False
    for singleton in (None, True, False):
        ctypes.c_ssize_t.from_address(id(singleton)).value += _EXTRA_REFERENCES
    _applied = True
    import PySide6

    log.info("PySide6 %s loses references to None/True/False on Python %s (%s per call): they are made "
             "immortal, as on 3.12; PySide6 6.11 does not need this", PySide6.__version__,
             sys.version.split()[0], leaks)
    return True


guard_none_refcount()  # on import, before any widget exists
