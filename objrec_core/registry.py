"""The registry: module types, data kinds and source types by name, from entry points or registered in code.

Entry-point groups (see docs/writing-a-filter.md and docs/architecture.md):

- ``objrec.modules``: name = the module type written in parameter files, value = ``package.module:Class``.
- ``objrec.kinds``: name = a data kind (``2d``, ``3d``), value = ``package.module:KindClass`` (a
  :class:`~objrec_core.kinds.Kind` subclass or instance).
- ``objrec.sources``: name = ``KIND.NAME`` (``2d.demo``), value = ``package.module:SourceClass`` (a
  :class:`~objrec_core.sources.FrameSource` subclass). The kind prefix lets a 2D run load only 2D sources.

Entry points are read once and loaded lazily, one type at a time, so a 2D parameter file never imports
Open3D. Code (scripts, tests) can register the same things with ``register_module``, ``register_kind`` and
``register_source``.
"""

from __future__ import annotations

import functools
import logging
import stat
import threading
from importlib.metadata import EntryPoint, entry_points
from typing import Any, TypeVar

from strictio.opener import describe_mode

from .kinds import Kind
from .parametrizable import Parametrizable
from .sources import FrameSource, SourceError, SourceSpec

log = logging.getLogger(__name__)

MODULE_GROUP = "objrec.modules"
KIND_GROUP = "objrec.kinds"
SOURCE_GROUP = "objrec.sources"

_lock = threading.RLock()
_modules: dict[str, type[Parametrizable]] = {}
_kinds: dict[str, Kind] = {}
_sources: dict[str, type[FrameSource]] = {}

T = TypeVar("T", bound=type[Parametrizable])
S = TypeVar("S", bound=type[FrameSource])


class UnknownModuleError(LookupError):
    """A module type, data kind or source type that is neither registered nor installed as an entry point,
    or whose plug-in cannot be loaded."""


@functools.cache
def _entry_points(group: str) -> dict[str, EntryPoint]:
    """Installed entry points, read once: scanning every package's metadata costs milliseconds."""
    return {ep.name: ep for ep in entry_points(group=group)}


def refresh() -> None:
    """Forget the entry points read so far (after installing a plug-in into a running process)."""
    _entry_points.cache_clear()
    with _lock:
        _kinds.clear()
        _sources.clear()


def _load(ep: EntryPoint, what: str) -> Any:
    try:
        return ep.load()
    except Exception as exc:  # a broken plug-in must not take the app down with a traceback
        raise UnknownModuleError(f"{what} {ep.name!r} from {ep.value} cannot be loaded: {exc}") from exc


# -- module types -----------------------------------------------------------------------------------------
def register_module(cls: T) -> T:
    """Register a module type under its ``type_name`` (usable as a decorator). Entry points are the way
    for installed packages; this is for scripts and tests."""
    if not (isinstance(cls, type) and issubclass(cls, Parametrizable)):
        raise TypeError(f"{cls!r} is not a Parametrizable subclass")
    with _lock:
        previous = _modules.get(cls.type_name)
        if previous is not None and previous is not cls:
            log.warning("module type %s re-registered: %r replaces %r", cls.type_name, cls, previous)
        _modules[cls.type_name] = cls
    return cls


def unregister_module(name: str) -> None:
    with _lock:
        _modules.pop(name, None)


def module_type_names() -> list[str]:
    """Every known type name, without importing any module."""
    with _lock:
        names = set(_modules)
    return sorted(names | set(_entry_points(MODULE_GROUP)))


def module_type(name: str) -> type[Parametrizable]:
    """The class registered under ``name``; loads its entry point on first use."""
    with _lock:
        if name in _modules:
            return _modules[name]
    ep = _entry_points(MODULE_GROUP).get(name)
    if ep is None:
        known = ", ".join(module_type_names()) or "none"
        raise UnknownModuleError(f"unknown module type {name!r} (known: {known})")
    klass = _load(ep, "module type")
    if not (isinstance(klass, type) and issubclass(klass, Parametrizable)):
        raise UnknownModuleError(f"entry point {name} = {ep.value} is not a Parametrizable subclass")
    if klass.type_name != name:
        raise UnknownModuleError(f"entry point {name} = {ep.value} declares type_name {klass.type_name!r}")
    with _lock:
        return _modules.setdefault(name, klass)


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


# -- data kinds -------------------------------------------------------------------------------------------
def register_kind(kind: Kind | type[Kind]) -> Kind:
    """Register a data kind (an instance, or a class made with no arguments)."""
    instance = kind() if isinstance(kind, type) else kind
    if not isinstance(instance, Kind):
        raise TypeError(f"{kind!r} is not a Kind")
    with _lock:
        _kinds[instance.name] = instance
    return instance


def unregister_kind(name: str) -> None:
    with _lock:
        _kinds.pop(name, None)


def kind_names() -> list[str]:
    """Every known data kind, without importing any."""
    with _lock:
        names = set(_kinds)
    return sorted(names | set(_entry_points(KIND_GROUP)))


def get_kind(name: str) -> Kind:
    """The data kind registered under ``name``."""
    with _lock:
        if name in _kinds:
            return _kinds[name]
    ep = _entry_points(KIND_GROUP).get(name) if isinstance(name, str) else None
    if ep is None:
        raise UnknownModuleError(f"unknown data kind {name!r} (known: {', '.join(kind_names()) or 'none'})")
    loaded = _load(ep, "data kind")
    instance = loaded() if isinstance(loaded, type) else loaded
    if not isinstance(instance, Kind):
        raise UnknownModuleError(f"entry point {name} = {ep.value} is not a Kind")
    if instance.name != name:
        raise UnknownModuleError(f"entry point {name} = {ep.value} names its kind {instance.name!r}")
    with _lock:
        return _kinds.setdefault(name, instance)


# -- source types -----------------------------------------------------------------------------------------
def register_source(cls: S) -> S:
    """Register a source type (usable as a decorator); its ``kind`` must be set."""
    if not (isinstance(cls, type) and issubclass(cls, FrameSource)) or not cls.kind:
        raise TypeError(f"{cls!r} is not a FrameSource subclass with a kind")
    with _lock:
        _sources[f"{cls.kind}.{cls.__name__}"] = cls
    return cls


def unregister_source(cls: type[FrameSource]) -> None:
    with _lock:
        _sources.pop(f"{cls.kind}.{cls.__name__}", None)


def source_types(kind: str | None = None) -> list[type[FrameSource]]:
    """The source types of a kind (or of every kind), loading their entry points; broken ones are logged."""
    found: dict[str, type[FrameSource]] = {}
    for name, ep in _entry_points(SOURCE_GROUP).items():
        ep_kind = name.split(".", 1)[0]
        if kind is not None and ep_kind != kind:
            continue
        try:
            klass = _load(ep, "source type")
        except UnknownModuleError as exc:
            log.warning("%s", exc)
            continue
        if not (isinstance(klass, type) and issubclass(klass, FrameSource)) or klass.kind != ep_kind:
            log.warning("entry point %s = %s is not a FrameSource of kind %s", name, ep.value, ep_kind)
            continue
        found[f"{klass.kind}.{klass.__name__}"] = klass
    with _lock:
        found.update({k: v for k, v in _sources.items() if kind is None or v.kind == kind})
    return list(found.values())


def source_usage(kind: str | None = None) -> str:
    """The schemes and extensions accepted, for messages."""
    types = source_types(kind)
    schemes = sorted({f"{s}:" for t in types for s in t.schemes})
    extensions = sorted({e for t in types for e in t.extensions})
    parts = []
    if schemes:
        parts.append("schemes " + ", ".join(schemes))
    if extensions:
        parts.append("files " + " ".join(extensions))
    if any(t.folders for t in types):
        parts.append("folders")
    return "; ".join(parts) or "none installed"


def _choose(spec: SourceSpec, types: list[type[FrameSource]]) -> tuple[int, list[type[FrameSource]]]:
    """The best-matching types and how well they match (2: by scheme, extension or content; 1: fallback)."""
    if spec.scheme is not None:
        return 2, [t for t in types if spec.scheme in t.schemes]
    assert spec.path is not None
    if not spec.path.exists():
        return 0, []
    scores = [(t.path_score(spec.path), t) for t in types]
    best = max((s for s, _ in scores), default=0)
    return best, [t for s, t in scores if s == best and s > 0]


def source_kinds(text: str) -> list[str]:
    """The kinds that have a source for this spec (``demo`` has one in every built-in kind)."""
    types = source_types()
    spec = SourceSpec.parse(text, {s for t in types for s in t.schemes})
    return sorted({t.kind for t in _choose(spec, types)[1] if t.kind})


def open_source(text: str, kind: str | None = None) -> FrameSource:
    """Open the source a user named, for a data kind (None: whichever kind has a source for it).

    SourceError says what is wrong and, for a spec no source type takes, lists the accepted schemes and
    extensions.
    """
    if kind is not None:
        get_kind(kind)  # an unknown kind is an error of its own
    every = source_types()
    spec = SourceSpec.parse(text, {s for t in every for s in t.schemes})
    if spec.path is not None and spec.path.exists() and not (spec.path.is_file() or spec.path.is_dir()):
        # a FIFO would block a reader forever and a device never ends: no source type is asked about it
        mode = spec.path.stat().st_mode
        cameras = any("camera" in t.schemes for t in every)
        hint = " (for a camera, give camera:N)" if stat.S_ISCHR(mode) and cameras else ""
        raise SourceError(f"{spec.text}: is {describe_mode(mode)}, not a regular file{hint}")
    score, chosen = _choose(spec, [t for t in every if kind is None or t.kind == kind])
    what = f"{kind} " if kind else ""
    if kind is not None and score < 2:  # a fallback match loses to another kind's own extension
        best, _ = _choose(spec, [t for t in every if t.kind != kind])
        if best > score:
            chosen = []
    if not chosen:
        if spec.path is not None and not spec.path.exists():
            raise SourceError(f"{spec.text}: no such file or folder ({what}sources: {source_usage(kind)})")
        others = [k for k in source_kinds(text) if k != kind] if kind else []
        if others:
            raise SourceError(f"{spec.text}: a source of {', '.join(others)} data, but this pipeline works on "
                              f"{kind} data")
        if spec.scheme is not None:
            raise SourceError(f"{spec.text}: unknown source scheme {spec.scheme}: ({what}sources: "
                              f"{source_usage(kind)})")
        raise SourceError(f"{spec.text}: no {what}source reads this ({what}sources: {source_usage(kind)})")
    kinds = sorted({t.kind for t in chosen if t.kind})
    if len(kinds) > 1:
        raise SourceError(f"{spec.text}: a source of several kinds ({', '.join(kinds)}); the pipeline's kind "
                          "decides which, so open a parameter file or add a module first")
    if len(chosen) > 1:
        names = ", ".join(t.__name__ for t in chosen)
        raise SourceError(f"{spec.text}: several {what}source types read this ({names}); name one by its scheme")
    source_type = chosen[0]
    options = source_type.typed_options(spec)
    return source_type.from_spec(spec, options)

