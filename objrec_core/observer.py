"""Subject/Observer, the seed's Document-View binding between modules and their views.

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
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

log = logging.getLogger(__name__)


@runtime_checkable
class Observer(Protocol):
    """Anything with ``update(subject)``."""

    def update(self, subject: Any) -> None: ...


class _CallbackObserver:
    def __init__(self, callback: Callable[[Any], None]) -> None:
        self.callback = callback

    def update(self, subject: Any) -> None:
        self.callback(subject)


class Subject:
    """Keeps observers and calls ``update(self)`` on each after a change."""

    def __init__(self) -> None:
        self._observers: list[Observer] = []
        self._observers_lock = threading.Lock()

    def add_observer(self, observer: Observer) -> None:
        if not callable(getattr(observer, "update", None)):
            raise TypeError(f"{observer!r} has no update(subject) method")
        with self._observers_lock:
            if observer not in self._observers:
                self._observers.append(observer)

    def remove_observer(self, observer: Observer) -> None:
        with self._observers_lock:
            if observer in self._observers:
                self._observers.remove(observer)

    def watch(self, callback: Callable[[Any], None]) -> Observer:
        """Register a plain function as an observer; returns the observer so it can be removed."""
        observer = _CallbackObserver(callback)
        self.add_observer(observer)
        return observer

    @property
    def observers(self) -> tuple[Observer, ...]:
        with self._observers_lock:
            return tuple(self._observers)

    def notify(self) -> None:
        for observer in self.observers:
            try:
                observer.update(self)
            except Exception:
                log.exception("observer %r failed while being notified by %r", observer, self)
