"""The module registry: module types by name, from entry points or registered in code.

Entry-point groups (see docs/writing-a-filter.md):

- ``objrec.modules``: name = the module type written in parameter files, value = ``package.module:Class``.
- ``objrec.kinds``: name = a data kind (``2d``, ``3d``), value = a module with ``open_source(spec)``
  and ``annotate(frame, objects)``; this is how the apps open sources without importing OpenCV or Open3D
  themselves.

Entry points are loaded lazily, one type at a time, so a 2D parameter file never imports Open3D.
"""

from __future__ import annotations

import functools
import importlib
import logging
import threading
from importlib.metadata import EntryPoint, entry_points
from types import ModuleType
from typing import TypeVar

from .parametrizable import Parametrizable

log = logging.getLogger(__name__)

MODULE_GROUP = "objrec.modules"
KIND_GROUP = "objrec.kinds"

_lock = threading.RLock()
_registered: dict[str, type[Parametrizable]] = {}
_kinds: dict[str, ModuleType] = {}

T = TypeVar("T", bound=type[Parametrizable])


class UnknownModuleError(LookupError):
    """A module type that is neither registered nor installed as an entry point."""


@functools.cache
def _entry_points(group: str) -> dict[str, EntryPoint]:
    """Installed entry points, read once: scanning every package's metadata costs milliseconds."""
    return {ep.name: ep for ep in entry_points(group=group)}


def refresh() -> None:
    """Forget the entry points read so far (after installing a plug-in into a running process)."""
    _entry_points.cache_clear()
    with _lock:
        _kinds.clear()


def register_module(cls: T) -> T:
    """Register a module type under its ``type_name`` (usable as a decorator). Entry points are the way
    for installed packages; this is for scripts and tests. To use another name in files, set ``type_name``
    on the class."""

    def add(klass: T) -> T:
        if not (isinstance(klass, type) and issubclass(klass, Parametrizable)):
            raise TypeError(f"{klass!r} is not a Parametrizable subclass")
        type_name = klass.type_name
        with _lock:
            previous = _registered.get(type_name)
            if previous is not None and previous is not klass:
                log.warning("module type %s re-registered: %r replaces %r", type_name, klass, previous)
            _registered[type_name] = klass
        return klass

    return add(cls)


def unregister_module(name: str) -> None:
    with _lock:
        _registered.pop(name, None)


def module_type_names() -> list[str]:
    """Every known type name, without importing any module."""
    with _lock:
        names = set(_registered)
    return sorted(names | set(_entry_points(MODULE_GROUP)))


def module_type(name: str) -> type[Parametrizable]:
    """The class registered under ``name``; loads its entry point on first use."""
    with _lock:
        if name in _registered:
            return _registered[name]
    ep = _entry_points(MODULE_GROUP).get(name)
    if ep is None:
        known = ", ".join(module_type_names()) or "none"
        raise UnknownModuleError(f"unknown module type {name!r} (known: {known})")
    try:
        klass = ep.load()
    except Exception as exc:  # a broken plug-in must not take the app down with a traceback
        raise UnknownModuleError(f"module type {name!r} from {ep.value} cannot be loaded: {exc}") from exc
    if not (isinstance(klass, type) and issubclass(klass, Parametrizable)):
        raise UnknownModuleError(f"entry point {name} = {ep.value} is not a Parametrizable subclass")
    if klass.type_name != name:
        raise UnknownModuleError(f"entry point {name} = {ep.value} declares type_name {klass.type_name!r}")
    with _lock:
        return _registered.setdefault(name, klass)


def module_types(kind: str | None = None) -> dict[str, type[Parametrizable]]:
    """Load every module type (for a GUI's Pipeline menu); types that fail to load are logged and skipped."""
    found = {}
    for name in module_type_names():
        try:
            klass = module_type(name)
        except UnknownModuleError as exc:
            log.warning("%s", exc)
            continue
        if kind is None or klass.kind == kind:
            found[name] = klass
    return found


def kind_names() -> list[str]:
    return sorted(_entry_points(KIND_GROUP))


def kind_plugin(kind: str) -> ModuleType:
    """The module that opens sources and draws annotations for a data kind."""
    plugin = _kinds.get(kind)
    if plugin is not None:
        return plugin
    ep = _entry_points(KIND_GROUP).get(kind)
    if ep is None:
        raise UnknownModuleError(f"unknown data kind {kind!r} (known: {', '.join(kind_names()) or 'none'})")
    try:
        plugin = importlib.import_module(ep.value)
    except ImportError as exc:
        raise UnknownModuleError(f"data kind {kind!r} needs {ep.value}, which cannot be imported: {exc}") from exc
    with _lock:
        return _kinds.setdefault(kind, plugin)
