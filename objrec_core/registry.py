"""The registry: module types, data kinds and source types by name, from entry points or registered in code.

All three are :class:`declare.registry.Registry` groups, so they share one set of rules: the key is the
entry-point name; entry points are read once and loaded lazily, one at a time; a broken plug-in is one
UnknownModuleError naming the entry point and its distribution; two distributions declaring one name, or a
code registration taking a name another object holds, are refused with a message naming both.

Entry-point groups (see docs/writing-a-filter.md and docs/architecture.md):

- ``objrec.modules``: name = the module type written in parameter files, value = ``package.module:Class``
  (a Parametrizable subclass whose ``type_name`` is the name).
- ``objrec.kinds``: name = a data kind (``2d``, ``3d``), value = ``package.module:KindClass`` (a
  :class:`~objrec_core.kinds.Kind` subclass or instance whose ``name`` is the name).
- ``objrec.sources``: name = ``KIND.NAME`` (``2d.demo``), value = a
  :class:`~objrec_core.sources.FrameSource` subclass of that kind, or a
  :class:`~objrec_core.source_declaration.DeclaredSource` (its kind, schemes, extensions and marker-file
  folders, and where the implementation lives) for a source whose module is heavy to import.

Which sources are loaded: a run of one kind looks only at the entry points named ``KIND.*`` of its kind.
Their schemes and extensions come from the declarations (a FrameSource class declares its own; a
DeclaredSource does without importing the implementation), and an implementation behind a declaration is
imported only when a spec chose it. So ``open_source("demo", "2d")`` imports objrec2d's sources and no
objrec3d or objrec_ros module. The other kinds are consulted only to word an error ("a source of 3d data,
but this pipeline works on 2d data") or when the asked kind reads a path only as a fallback (a folder, a
video of an unknown suffix), to let another kind's own reader of it win.

Code (scripts, tests) registers the same things with ``register_module``, ``register_kind`` and
``register_source``.
"""

from __future__ import annotations

import logging
import stat
from collections.abc import Callable
from typing import Any, TypeVar

from declare.registry import Registry, distribution_of
from strictio.opener import describe_mode

from .kinds import Kind
from .parametrizable import Parametrizable
from .source_declaration import DeclaredSource
from .sources import FrameSource, SourceError, SourceSpec

log = logging.getLogger(__name__)

MODULE_GROUP = "objrec.modules"
KIND_GROUP = "objrec.kinds"
SOURCE_GROUP = "objrec.sources"

T = TypeVar("T", bound=type[Parametrizable])
S = TypeVar("S", bound=type[FrameSource])

#: What the source group holds: a FrameSource subclass, or the declaration of one.
SourceEntry = type[FrameSource] | DeclaredSource


class UnknownModuleError(LookupError):
    """A module type, data kind or source type that is neither registered nor installed as an entry point,
    whose plug-in cannot be loaded, or whose name two plug-ins claim."""


def _valid_module(name: str, obj: Any) -> type[Parametrizable]:
    if not (isinstance(obj, type) and issubclass(obj, Parametrizable)):
        raise TypeError(f"{obj!r} is not a Parametrizable subclass")
    if obj.type_name != name:
        raise ValueError(f"declares type_name {obj.type_name!r}, not {name!r}")
    return obj


def _valid_kind(name: str, obj: Any) -> Kind:
    instance = obj() if isinstance(obj, type) and issubclass(obj, Kind) else obj
    if not isinstance(instance, Kind):
        raise TypeError(f"{obj!r} is not a Kind")
    if instance.name != name:
        raise ValueError(f"names its kind {instance.name!r}, not {name!r}")
    return instance


def _valid_source(name: str, obj: Any) -> SourceEntry:
    kind, dot, rest = name.partition(".")
    if not (dot and kind and rest):
        raise ValueError(f"source names are KIND.NAME (2d.demo), not {name!r}")
    if not (isinstance(obj, DeclaredSource) or (isinstance(obj, type) and issubclass(obj, FrameSource))):
        raise TypeError(f"{obj!r} is not a FrameSource subclass or a DeclaredSource")
    if obj.kind != kind:
        raise ValueError(f"is a source of kind {obj.kind!r}, and its name says {kind!r}")
    return obj


def _source_name(obj: Any) -> str:
    kind = getattr(obj, "kind", None)
    if not kind:
        raise TypeError(f"{obj!r} is not a FrameSource subclass with a kind")
    return f"{kind}.{getattr(obj, '__name__', type(obj).__name__)}"


#: The three groups; the functions below are their public face (plug-in authors use those, not these).
MODULES: Registry[type[Parametrizable]] = Registry(
    MODULE_GROUP, "module type", error=UnknownModuleError, validate=_valid_module,
    name_of=lambda cls: getattr(cls, "type_name", None) or repr(cls))
KINDS: Registry[Kind] = Registry(
    KIND_GROUP, "data kind", error=UnknownModuleError, validate=_valid_kind,
    name_of=lambda kind: getattr(kind, "name", None) or repr(kind))
SOURCES: Registry[SourceEntry] = Registry(
    SOURCE_GROUP, "source type", error=UnknownModuleError, validate=_valid_source, name_of=_source_name)


def refresh() -> None:
    """Re-read the entry points of every group (after installing a plug-in into a running process)."""
    for registry in (MODULES, KINDS, SOURCES):
        registry.refresh()


# -- module types -----------------------------------------------------------------------------------------
def register_module(cls: T) -> T:
    """Register a module type under its ``type_name`` (usable as a decorator). Entry points are the way
    for installed packages; this is for scripts and tests. TypeError for a class that is not a module type;
    UnknownModuleError when another class holds the name."""
    MODULES.register(cls)
    return cls


def unregister_module(name: str) -> None:
    """Forget a module type registered in code; unknown names are ignored."""
    MODULES.unregister(name)


def module_type_names() -> list[str]:
    """Every known type name, without importing any module."""
    return MODULES.names()


def module_type(name: str) -> type[Parametrizable]:
    """The class registered under ``name``; loads its entry point on first use."""
    return MODULES.get(name)


def module_types(kind: str | None = None) -> dict[str, type[Parametrizable]]:
    """Load every module type (for a GUI's Pipeline menu); types that fail to load are logged and skipped."""
    return {name: klass for name, klass in MODULES.items().items() if kind is None or klass.kind == kind}


# -- data kinds -------------------------------------------------------------------------------------------
def register_kind(kind: Kind | type[Kind]) -> Kind:
    """Register a data kind (an instance, or a class made with no arguments) under its ``name``."""
    if isinstance(kind, type) and issubclass(kind, Kind):
        kind = kind()
    if not isinstance(kind, Kind):
        raise TypeError(f"{kind!r} is not a Kind")
    return KINDS.register(kind)


def unregister_kind(name: str) -> None:
    """Forget a data kind registered in code; unknown names are ignored."""
    KINDS.unregister(name)


def kind_names() -> list[str]:
    """Every known data kind, without importing any."""
    return KINDS.names()


def get_kind(name: str) -> Kind:
    """The data kind registered under ``name``; loads its entry point on first use."""
    return KINDS.get(name)


# -- source types -----------------------------------------------------------------------------------------
def register_source(cls: S, name: str | None = None) -> S:
    """Register a source type (usable as a decorator) under ``KIND.NAME``; by default ``KIND.ClassName``.
    Its ``kind`` must be set."""
    if not (isinstance(cls, type) and issubclass(cls, FrameSource)) or not cls.kind:
        raise TypeError(f"{cls!r} is not a FrameSource subclass with a kind")
    SOURCES.register(cls, name)
    return cls


def unregister_source(source: type[FrameSource] | str) -> None:
    """Forget a source type registered in code: by its ``KIND.NAME``, or every name a class is registered
    under."""
    if isinstance(source, str):
        SOURCES.unregister(source)
        return
    for name in SOURCES.names():
        if SOURCES.registered(name) is source:
            SOURCES.unregister(name)


def _of_kind(kind: str | None) -> Callable[[str], bool] | None:
    """Selects the source names of a kind (``2d.*``), so the other kinds' entry points stay unloaded."""
    return None if kind is None else (lambda name: name.partition(".")[0] == kind)


#: Source plug-ins that cannot be loaded, by name, and why. Every listing of sources meets them, so a warning
#: there put a line before every error of a command; they are named in the error of a spec no source
#: takes instead (the one place where a missing source matters), and logged at INFO (``--verbose``).
_BROKEN_SOURCES: dict[str, str] = {}


def _broken(name: str, exc: Exception) -> None:
    if name not in _BROKEN_SOURCES:
        log.info("%s", exc)
    _BROKEN_SOURCES[name] = str(exc)


def broken_sources(kind: str | None = None) -> list[str]:
    """Why each source plug-in of a kind (or of every kind) met so far cannot be loaded."""
    select = _of_kind(kind)
    return [why for name, why in sorted(_BROKEN_SOURCES.items()) if select is None or select(name)]


def source_entries(kind: str | None = None) -> dict[str, SourceEntry]:
    """The source types of a kind (or of every kind) by name, as declared: a FrameSource subclass, or a
    DeclaredSource whose implementation is not imported. Broken entry points are skipped (see
    :func:`broken_sources`)."""
    select = _of_kind(kind)
    found: dict[str, SourceEntry] = {}
    for name in SOURCES.names():
        if select is not None and not select(name):
            continue
        try:
            found[name] = SOURCES.get(name)
        except UnknownModuleError as exc:
            _broken(name, exc)
    return found


def source_schemes(kind: str | None = None) -> set[str]:
    """The schemes sources of a kind (or of every kind) accept, without importing any declared source."""
    return {s for entry in source_entries(kind).values() for s in entry.schemes}


def _implementation(name: str, entry: SourceEntry) -> type[FrameSource]:
    """The FrameSource subclass of an entry, importing a declared one's implementation."""
    if not isinstance(entry, DeclaredSource):
        return entry
    try:
        return entry.load()
    except Exception as exc:  # a broken plug-in is one line naming it
        ep = SOURCES.entry_points().get(name)
        origin = f" (declared by {ep[0].value} from {distribution_of(ep[0])})" if ep else ""
        raise UnknownModuleError(f"source type {name!r} = {entry.implementation}{origin} cannot be loaded: "
                                 f"{type(exc).__name__}: {exc}") from exc


def source_types(kind: str | None = None) -> list[type[FrameSource]]:
    """The source types of a kind (or of every kind), their implementations loaded; broken ones are logged.
    For schemes and extensions alone, :func:`source_entries` imports less."""
    found: list[type[FrameSource]] = []
    for name, entry in source_entries(kind).items():
        try:
            klass = _implementation(name, entry)
        except UnknownModuleError as exc:
            _broken(name, exc)
            continue
        if klass not in found:
            found.append(klass)
    return found


def source_usage(kind: str | None = None) -> str:
    """The schemes and extensions accepted, for messages (from the declarations: no implementation behind a
    DeclaredSource is imported)."""
    entries = list(source_entries(kind).values())
    schemes = sorted({f"{s}:" for t in entries for s in t.schemes})
    extensions = sorted({e for t in entries for e in t.extensions})
    parts = []
    if schemes:
        parts.append("schemes " + ", ".join(schemes))
    if extensions:
        parts.append("files " + " ".join(extensions))
    if any(t.folders or getattr(t, "folder_marker", "") for t in entries):
        parts.append("folders")
    return "; ".join(parts) or "none installed"


def _choose(spec: SourceSpec, entries: list[SourceEntry]) -> tuple[int, list[SourceEntry]]:
    """The best-matching entries and how well they match (2: by scheme, extension or content; 1: fallback)."""
    if spec.scheme is not None:
        return 2, [t for t in entries if spec.scheme in t.schemes]
    assert spec.path is not None
    if not spec.path.exists():
        return 0, []
    scores = [(t.path_score(spec.path), t) for t in entries]
    best = max((s for s, _ in scores), default=0)
    return best, [t for s, t in scores if s == best and s > 0]


def source_kinds(text: str) -> list[str]:
    """The kinds that have a source for this spec (``demo`` has one in every built-in kind)."""
    entries = list(source_entries().values())
    spec = SourceSpec.parse(text, {s for t in entries for s in t.schemes})
    return sorted({t.kind for t in _choose(spec, entries)[1] if t.kind})


def open_source(text: str, kind: str | None = None) -> FrameSource:
    """Open the source a user named, for a data kind (None: whichever kind has a source for it).

    Only the asked kind's sources are consulted to parse and choose (see the module docstring); SourceError
    says what is wrong and, for a spec no source type takes, lists the accepted schemes and extensions.
    """
    if kind is not None:
        get_kind(kind)  # an unknown kind is an error of its own
    _refuse_clashes(text, kind)
    named = source_entries(kind)
    entries = list(named.values())
    spec = SourceSpec.parse(text, {s for t in entries for s in t.schemes})
    if spec.path is not None and spec.path.exists() and not (spec.path.is_file() or spec.path.is_dir()):
        # a FIFO would block a reader forever and a device never ends: no source type is asked about it
        mode = spec.path.stat().st_mode
        cameras = any("camera" in t.schemes for t in entries)
        hint = " (for a camera, give camera:N)" if stat.S_ISCHR(mode) and cameras else ""
        raise SourceError(f"{spec.text}: is {describe_mode(mode)}, not a regular file{hint}")
    score, chosen = _choose(spec, entries)
    what = f"{kind} " if kind else ""
    if kind is not None and 0 < score < 2:  # a fallback match loses to another kind's own reader
        others = [t for name, t in source_entries().items() if name not in named]
        best, _ = _choose(spec, others)
        if best > score:
            chosen = []
    if not chosen:
        raise _no_source(spec, kind, what)
    kinds_chosen = sorted({t.kind for t in chosen if t.kind})
    if len(kinds_chosen) > 1:
        raise SourceError(f"{spec.text}: a source of several kinds ({', '.join(kinds_chosen)}); the pipeline's "
                          "kind decides which, so open a parameter file or add a module first")
    names = [name for name, t in named.items() if any(t is c for c in chosen)]
    types: list[type[FrameSource]] = []
    for name in names:
        try:
            klass = _implementation(name, SOURCES.get(name))
        except UnknownModuleError as exc:
            raise SourceError(f"{spec.text}: {exc}") from None
        if klass not in types:
            types.append(klass)
    if len(types) > 1:
        classes = ", ".join(t.__name__ for t in types)
        raise SourceError(f"{spec.text}: several {what}source types read this ({classes}); name one by its scheme")
    source_type = types[0]
    options = source_type.typed_options(spec)
    return source_type.from_spec(spec, options)


def _refuse_clashes(text: str, kind: str | None) -> None:
    """Two installed packages declaring one source name (``2d.demo`` twice) make every spec of that kind an
    error naming both: listing skips such a name, so opening would otherwise blame something else."""
    select = _of_kind(kind)
    for name, declared in SOURCES.entry_points().items():
        if len(declared) > 1 and (select is None or select(name)) and SOURCES.registered(name) is None:
            try:
                SOURCES.entry_point(name)
            except UnknownModuleError as exc:
                raise SourceError(f"{text}: {exc}") from None


def _no_source(spec: SourceSpec, kind: str | None, what: str) -> SourceError:
    """Why no source of the kind takes a spec: another kind's, no such file, an unknown scheme or nothing; the
    source plug-ins that cannot be loaded are named too (one of them may be the one meant)."""
    others = [k for k in source_kinds(spec.text) if k != kind] if kind else []
    if others:
        return SourceError(f"{spec.text}: a source of {', '.join(others)} data, but this pipeline works on "
                           f"{kind} data")
    broken = broken_sources(kind)
    usage = source_usage(kind) + ("; not loaded: " + "; ".join(broken) if broken else "")
    if spec.path is not None and not spec.path.exists():
        return SourceError(f"{spec.text}: no such file or folder ({what}sources: {usage})")
    if spec.scheme is not None:
        return SourceError(f"{spec.text}: unknown source scheme {spec.scheme}: ({what}sources: {usage})")
    return SourceError(f"{spec.text}: no {what}source reads this ({what}sources: {usage})")
