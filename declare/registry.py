"""One registry for every kind of plug-in: module types, data kinds, source types, patrol tasks.

A :class:`Registry` is a named group of plug-ins. Installed packages add to it through an entry-point group
(``[project.entry-points."objrec.modules"]`` and the like); scripts and tests add to it in code with
:meth:`Registry.register`. The same rules hold for every group, because the four hand-written registries
this replaces each had their own and plug-ins fell through the gaps between them:

- **The key is the entry-point name** (``HSVFilter``, ``2d.demo``, ``wait``), never the class's name: a
  plug-in source class called ``DemoSource`` registered as ``2d.mydemo`` is ``2d.mydemo``, and does not
  shadow the built-in ``2d.demo``. A code registration gives its name explicitly or takes the object's
  declared name (``type_name``, a kind's ``name``, a task's ``kind``) through the group's ``name_of``.
- **Entry points are read once** (scanning every package's metadata costs milliseconds) and **loaded lazily,
  one at a time**: asking for ``HSVFilter`` imports objrec2d's filter and nothing of objrec3d.
- **A broken plug-in is one clear error** (the group's error class) naming the entry point, its value and
  its distribution, instead of a traceback; listing every plug-in logs and skips it.
- **Duplicates are refused, never dropped in silence**: two distributions declaring the same name make
  looking that name up an error naming both; a code registration under a name another object holds (in
  code or as an entry point) is refused naming both origins. The same object twice is not a clash.
- **A validation hook per group** (``validate``) checks a loaded or registered object (a Parametrizable
  subclass whose ``type_name`` is the name, a Kind, ...) and may turn it into what the group holds (a Kind
  class into its instance).
- **Thread-safe**: a GUI's worker and its main thread may look plug-ins up at once.
- :meth:`Registry.refresh` re-reads the entry points (after installing a plug-in into a running process).

This module is in the floor (``declare``) so that ``navigation``, which may not import ``objrec_core``,
builds its task registry on the same class.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Iterator
from importlib.metadata import EntryPoint, entry_points
from typing import Any, Generic, TypeVar

log = logging.getLogger(__name__)

T = TypeVar("T")


class PluginError(LookupError):
    """A name that is neither registered nor installed, a plug-in that cannot be loaded or is not what its
    group holds, or two plug-ins claiming one name. The message names the entry point and its origin."""


def distribution_of(ep: EntryPoint) -> str:
    """The distribution an entry point comes from, for messages (``objrec 0.1.0``)."""
    dist = getattr(ep, "dist", None)
    if dist is None:
        return "an unknown distribution"
    try:
        return f"{dist.metadata['Name']} {dist.version}"
    except Exception:  # a damaged METADATA must not hide the real message
        return "an unreadable distribution"


def origin_of(obj: Any) -> str:
    """Where a plug-in comes from, in entry-point form: its ``registry_origin`` attribute if it has one (a
    declaration standing for an implementation elsewhere), else ``module:QualifiedName`` of a class or
    function, or of an instance's class (two instances of one Kind class are the same plug-in)."""
    declared = getattr(obj, "registry_origin", None)
    if isinstance(declared, str):
        return declared
    target = obj if isinstance(obj, type) or (callable(obj) and hasattr(obj, "__qualname__")) else type(obj)
    return f"{getattr(target, '__module__', '?')}:{getattr(target, '__qualname__', repr(target))}"


class Registry(Generic[T]):
    """A named group of plug-ins from an entry-point group plus registrations in code.

    ``what`` names one plug-in in messages (``"module type"``); ``error`` is the exception class raised
    (a LookupError subclass callers already catch); ``validate(name, obj)`` returns what the group holds or
    raises TypeError/ValueError saying why ``obj`` does not belong; ``name_of(obj)`` is an object's declared
    name, the default key of :meth:`register`.
    """

    def __init__(self, group: str | None, what: str, *, error: type[Exception] = PluginError,
                 validate: Callable[[str, Any], T] | None = None,
                 name_of: Callable[[Any], str] | None = None) -> None:
        self.group = group
        self.what = what
        self.error = error
        self._validate = validate or (lambda _name, obj: obj)
        self._name_of = name_of
        self._lock = threading.RLock()
        self._declared: dict[str, list[EntryPoint]] | None = None
        self._loaded: dict[str, T] = {}
        self._code: dict[str, T] = {}
        self._replaced: dict[str, list[T]] = {}

    def __repr__(self) -> str:
        return f"Registry({self.group!r}, {self.what!r})"

    # -- entry points -------------------------------------------------------------------------------------
    def entry_points(self) -> dict[str, list[EntryPoint]]:
        """The group's installed entry points by name, read once; a name may have several (a clash)."""
        with self._lock:
            if self._declared is None:
                declared: dict[str, list[EntryPoint]] = {}
                found = entry_points(group=self.group) if self.group else ()
                for ep in found:
                    same = declared.setdefault(ep.name, [])
                    if not any(o.value == ep.value and distribution_of(o) == distribution_of(ep) for o in same):
                        same.append(ep)
                self._declared = declared
            return self._declared

    def entry_point(self, name: str) -> EntryPoint | None:
        """The one entry point declaring ``name``, None if none does; a clash is an error naming both."""
        found = self.entry_points().get(name, [])
        if len(found) > 1:
            where = " and ".join(f"{ep.value} from {distribution_of(ep)}" for ep in found)
            raise self.error(f"{self.what} {name!r} is declared twice ({self.group} entry points): {where}; "
                             "uninstall one of them")
        return found[0] if found else None

    def refresh(self) -> None:
        """Re-read the entry points and forget what was loaded from them; registrations in code stay."""
        with self._lock:
            self._declared = None
            self._loaded.clear()

    # -- registrations in code ----------------------------------------------------------------------------
    def register(self, obj: Any, name: str | None = None) -> T:
        """Add ``obj`` under ``name`` (default: its declared name) and return what the group holds for it.

        Raises TypeError when ``obj`` does not belong in the group, and the group's error when another
        object already holds the name (registering the same object again is allowed).
        """
        if name is None:
            if self._name_of is None:
                raise TypeError(f"registering a {self.what} needs a name")
            name = self._name_of(obj)
        held = self._validate(name, obj)
        origin = origin_of(held)
        with self._lock:
            previous = self._code.get(name)
            if previous is not None and previous is not held and origin_of(previous) != origin:
                raise self.error(f"{self.what} {name!r} is already registered by {origin_of(previous)}; "
                                 f"{origin} cannot take its name (unregister it first)")
            if previous is None:
                self._check_entry_point_clash(name, obj, held, origin)
            self._code[name] = held
        return held

    def _check_entry_point_clash(self, name: str, obj: Any, held: Any, origin: str) -> None:
        """Refuse a code registration of an installed name, unless it is the installed object itself (by its
        ``module:Name``, or, for a re-exported one, by loading the entry point and comparing)."""
        for ep in self.entry_points().get(name, []):
            if "".join(ep.value.split("[")[0].split()) == origin or self._loaded.get(name) is held:
                continue
            try:
                installed = ep.load()
            except Exception:  # a broken installed plug-in is still a different object
                installed = None
            if installed is not None and (installed is obj or origin_of(installed) == origin):
                continue
            raise self.error(f"{self.what} {name!r} is installed as {ep.value} from {distribution_of(ep)}; "
                             f"{origin} cannot take its name")

    def unregister(self, name: str) -> None:
        """Forget a registration in code (and anything loaded under the name); unknown names are ignored."""
        with self._lock:
            self._code.pop(name, None)
            self._loaded.pop(name, None)

    @contextlib.contextmanager
    def replaced(self, name: str, obj: Any) -> Iterator[T]:
        """``obj`` under ``name`` for the duration of a ``with`` block, whatever holds the name (a test checking
        a variant of an installed plug-in); afterwards the name is what it was. The one sanctioned way to
        shadow a plug-in, so that it is never done by accident."""
        held = self._validate(name, obj)
        with self._lock:
            self._replaced.setdefault(name, []).append(held)
        try:
            yield held
        finally:
            with self._lock:
                stack = self._replaced[name]
                stack.pop()
                if not stack:
                    del self._replaced[name]

    # -- look-ups -----------------------------------------------------------------------------------------
    def names(self) -> list[str]:
        """Every known name, sorted, without loading any plug-in."""
        with self._lock:
            code = set(self._code) | set(self._replaced)
        return sorted(code | set(self.entry_points()))

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self.names()

    def registered(self, name: str) -> T | None:
        """What is registered in code or already loaded under ``name``, without loading anything."""
        with self._lock:
            if name in self._replaced:
                return self._replaced[name][-1]
            return self._code.get(name, self._loaded.get(name))

    def get(self, name: str) -> T:
        """The plug-in named ``name``: registered in code, or its entry point loaded on first use."""
        found = self.registered(name) if isinstance(name, str) else None
        if found is not None:
            return found
        ep = self.entry_point(name) if isinstance(name, str) else None
        if ep is None:
            known = ", ".join(self.names()) or "none"
            raise self.error(f"unknown {self.what} {name!r} (known: {known})")
        held = self.load(ep)
        with self._lock:
            return self._loaded.setdefault(name, held)

    def load(self, ep: EntryPoint) -> T:
        """Import one entry point and validate it; any failure is the group's error naming the entry point."""
        where = f"{self.what} {ep.name!r} = {ep.value} (from {distribution_of(ep)})"
        try:
            obj = ep.load()
        except Exception as exc:  # a broken plug-in must not take the app down with a traceback
            raise self.error(f"{where} cannot be loaded: {type(exc).__name__}: {exc}") from exc
        try:
            return self._validate(ep.name, obj)
        except (TypeError, ValueError) as exc:
            raise self.error(f"{where}: {exc}") from None

    def items(self, select: Callable[[str], bool] | None = None) -> dict[str, T]:
        """Every plug-in whose name ``select`` accepts, loaded; broken ones are logged and skipped."""
        found: dict[str, T] = {}
        for name in self.names():
            if select is not None and not select(name):
                continue
            try:
                found[name] = self.get(name)
            except self.error as exc:
                log.warning("%s", exc)
        return found
