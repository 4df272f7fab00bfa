"""Subject/Observer: how views and workers hear of changes, and exactly which.

Every notification carries the changes that caused it, as :class:`Change` records (what changed, its old
and new value), as HoloViz ``param``'s events do: a panel updates the one widget whose value moved, the
processing worker reprocesses only when something that matters changed.

Threading contract: observers may be added, removed and notified from any thread. ``notify`` calls each
observer synchronously in the thread that made the change (for a parameter set from the GUI, the GUI
thread; for a change made by a worker, the worker). An observer that touches a GUI must hand the work to
its GUI thread itself (a queued Qt signal does this). The observer list is copied under a lock before it is
walked, so an observer may remove itself during ``update``. An observer that raises is logged and the
others are still notified: one broken view must not stop the pipeline.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Change:
    """One change: ``subject`` is what changed, ``name`` which part of it.

    For a module, ``name`` is a parameter name, ``"state"`` (its target or other saved state) or
    ``"object_name"``; for a recognition system, ``"pipeline"``, ``"object_name"`` or ``"description"``.
    """

    subject: Any
    name: str
    old: Any = None
    new: Any = None


@runtime_checkable
class Observer(Protocol):
    """Anything with ``update(subject, changes)``."""

    def update(self, subject: Any, changes: Sequence[Change]) -> None: ...


class _Watcher:
    def __init__(self, callback: Callable[[Sequence[Change]], None], names: Collection[str] | None) -> None:
        self.callback = callback
        self.names = None if names is None else frozenset(names)

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        if self.names is not None:
            changes = [c for c in changes if c.name in self.names]
            if not changes:
                return
        self.callback(changes)


class Subject:
    """Keeps observers and calls ``update(self, changes)`` on each after a change."""

    def __init__(self) -> None:
        self._observers: list[Observer] = []
        self._observers_lock = threading.Lock()

    def add_observer(self, observer: Observer) -> None:
        if not callable(getattr(observer, "update", None)):
            raise TypeError(f"{observer!r} has no update(subject, changes) method")
        with self._observers_lock:
            if observer not in self._observers:
                self._observers.append(observer)

    def remove_observer(self, observer: Observer) -> None:
        with self._observers_lock:
            if observer in self._observers:
                self._observers.remove(observer)

    def watch(self, callback: Callable[[Sequence[Change]], None], names: Collection[str] | None = None) -> Observer:
        """Call ``callback(changes)`` after each change (only changes of ``names``, where given); returns the
        observer so it can be removed."""
        observer = _Watcher(callback, names)
        self.add_observer(observer)
        return observer

    @property
    def observers(self) -> tuple[Observer, ...]:
        with self._observers_lock:
            return tuple(self._observers)

    def notify(self, changes: Sequence[Change] = ()) -> None:
        changes = tuple(changes)
        for observer in self.observers:
            try:
                observer.update(self, changes)
            except Exception:
                log.exception("observer %r failed while being notified by %r", observer, self)
