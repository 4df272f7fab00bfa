"""Frames, frame sources, and the one grammar every source is named with.

A source spec is either a path (a file or a folder, chosen by extension or content) or
``scheme:key=value,...``, where values given without a key fill the source type's positional options in
order: ``demo``, ``demo:seed=3,frames=100``, ``camera:0``, ``rgbd:color.png,depth.png``. Source types are
plug-ins (``objrec.sources`` entry points); each declares its kind, schemes, extensions and options, the
options with the same declarations as module parameters, so they are validated the same way.
"""

from __future__ import annotations

import re
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from declare.parameters import Parameter, ParameterError, short_repr


class SourceError(RuntimeError):
    """A source that cannot be opened, fails mid-stream or yields a corrupt frame; says which and why."""


@dataclass
class Frame:
    """One input frame: its data, when it was taken, its number, where it came from, ground truth where the
    source knows it, the coordinate frame it is in (``frame_id``, as a ROS header has it), and the exact time
    in nanoseconds where the source has one (``stamp_ns``: a recorded message's own stamp)."""

    data: Any
    stamp: float = field(default_factory=time.time)
    index: int = 0
    source: str = ""
    truth: Any = None
    frame_id: str = ""
    stamp_ns: int | None = None


_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+_.-]+):(.*)$", re.DOTALL)


@dataclass(frozen=True)
class SourceSpec:
    """A parsed source spec: a scheme with raw option texts, or a path."""

    text: str
    scheme: str | None = None
    options: Mapping[str, str] = field(default_factory=dict)
    positional: tuple[str, ...] = ()
    path: Path | None = None

    @classmethod
    def parse(cls, text: str, schemes: set[str]) -> SourceSpec:
        """``schemes`` are the registered ones: ``c:`` on a drive or ``name:`` in a file name stays a path."""
        text = text.strip()
        if not text:
            raise SourceError("no source given")
        match = _SCHEME.match(text)
        scheme = match.group(1).lower() if match else text.lower()
        if match and scheme in schemes:
            rest = match.group(2)
        elif not match and scheme in schemes and not Path(text).exists():
            rest = ""
        else:
            return cls(text, path=Path(text).expanduser())
        options: dict[str, str] = {}
        positional: list[str] = []
        for part in rest.split(",") if rest else []:
            key, sep, value = part.partition("=")
            if sep and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key.strip()):
                key = key.strip()
                if key in options:
                    raise SourceError(f"{text}: option {key} is given twice")
                options[key] = value.strip()
            else:
                if options:
                    raise SourceError(f"{text}: {short_repr(part)} has no key=, and options without one go first")
                positional.append(part.strip())
        return cls(text, scheme, options, tuple(positional))


class FrameSource(ABC):
    """An iterable of frames that knows its name and, where it can, its length.

    A source *type* is a subclass that declares how users name it, and is registered by entry point:

    - ``kind``: the data kind of its frames; ``schemes``: ``("demo",)`` for ``demo:...`` specs;
      ``extensions``: file suffixes it reads (``(".png", ".jpg")``); ``folders``: whether it reads a folder;
    - ``options``: ``{name: Int(...)/Float/Bool/Str/Choice}`` (or a plug-in's parameter type), read from
      text by the declaration's ``parse_text`` and validated like module parameters;
      ``positional``: the option names that values without ``key=`` fill, in order;
    - ``from_spec(spec, options)``: makes the source (options already typed and validated).

    Sources are context managers; ``close`` releases a camera or file. A source that ends simply stops
    iterating; one that fails raises SourceError naming itself.
    """

    kind: ClassVar[str | None] = None
    schemes: ClassVar[tuple[str, ...]] = ()
    extensions: ClassVar[tuple[str, ...]] = ()
    folders: ClassVar[bool] = False
    options: ClassVar[Mapping[str, Parameter]] = {}
    positional: ClassVar[tuple[str, ...]] = ()
    #: One line for lists of accepted sources ("demo[:seed=N,frames=N]  the synthetic scene").
    summary: ClassVar[str] = ""

    #: How the user named this source (a path, ``camera:0``, ``demo``).
    name: str = ""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for option_name, spec in cls.options.items():
            if spec.name != option_name:
                spec.bind(option_name, cls.__name__)
        unknown = [p for p in cls.positional if p not in cls.options]
        if unknown:
            raise TypeError(f"{cls.__name__}: positional options {unknown} are not declared in options")
        cls.extensions = tuple(e.lower() for e in cls.extensions)
        cls.schemes = tuple(s.lower() for s in cls.schemes)

    # -- how a spec reaches a source ----------------------------------------------------------------------
    @classmethod
    def path_score(cls, path: Path) -> int:
        """How well this type reads ``path``: 0 not at all, 1 as a fallback, 2 by its extension or content.

        The default matches ``extensions`` and, with ``folders``, any folder (1: a more specific type, such
        as a ROS 2 bag folder, wins by overriding this).
        """
        if path.is_dir():
            return 1 if cls.folders else 0
        return 2 if path.suffix.lower() in cls.extensions else 0

    @classmethod
    def typed_options(cls, spec: SourceSpec) -> dict[str, Any]:
        """The spec's options, typed and validated against the declarations, defaults filled in."""
        if len(spec.positional) > len(cls.positional):
            expected = ",".join(cls.positional) or "no values without a key"
            raise SourceError(f"{spec.text}: too many values without a key (this source takes {expected})")
        raw = dict(zip(cls.positional, spec.positional, strict=False))
        for key, value in spec.options.items():
            if key in raw:
                raise SourceError(f"{spec.text}: option {key} is given twice")
            raw[key] = value
        values = {name: option.default for name, option in cls.options.items()}
        for key, text in raw.items():
            option = cls.options.get(key)
            if option is None:
                known = ", ".join(cls.options) or "none"
                raise SourceError(f"{spec.text}: unknown option {short_repr(key)} (options: {known})")
            try:
                values[key] = option.parse_text(text, spec.scheme or cls.__name__)
            except ParameterError as exc:
                raise SourceError(f"{spec.text}: option {key}={short_repr(text)} is invalid: {exc.rule}") from None
        return values

    @classmethod
    def usage(cls) -> str:
        """The forms of spec this type accepts, for error messages and ``--help``."""
        forms = []
        for scheme in cls.schemes:
            forms.append(f"{scheme}:" + ",".join(f"{n}=…" for n in cls.options) if cls.options else scheme)
        if cls.extensions:
            forms.append("*" + " *".join(cls.extensions))
        if cls.folders:
            forms.append("a folder")
        return " | ".join(forms)

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> FrameSource:
        """Make the source; raise SourceError naming the spec when it cannot be opened. A source type that
        users name in specs overrides this; one only made in code need not."""
        raise SourceError(f"{spec.text}: {cls.__name__} cannot be opened from a spec")

    # -- the frames -----------------------------------------------------------------------------------------
    def __len__(self) -> int:
        """Number of frames, where known (files, folders); raises TypeError for endless sources."""
        length = self.length
        if length is None:
            raise TypeError(f"source {self.name!r} has no known length")
        return length

    @property
    def length(self) -> int | None:
        return None

    @property
    def rate(self) -> float | None:
        """Frames per second the recording was made at, where known (videos, the demo); None for cameras."""
        return None

    @abstractmethod
    def __iter__(self) -> Iterator[Frame]: ...

    # -- seeking (optional) -----------------------------------------------------------------------------
    @property
    def seekable(self) -> bool:
        """Whether ``frames_from`` can start anywhere: recordings of known length (videos, folders, files,
        bags) can, so a viewer can jump to frame N and loop; cameras and endless scenes cannot."""
        return False

    def frames_from(self, index: int) -> Iterator[Frame]:
        """The frames from number ``index`` on (numbered as a full iteration numbers them), without reading
        the ones before where the source can skip them; an index past the end gives no frames. Only where
        ``seekable``: SourceError otherwise. A fresh iterator each call, independent of ``__iter__``'s."""
        raise SourceError(f"{self.name}: this source cannot start at frame {index} (it is not seekable)")

    # -- live sources (optional) --------------------------------------------------------------------------
    def watch_stop(self, stop: threading.Event) -> None:  # noqa: B027 - most sources never wait without end
        """Hear of the run's stop request. A source that may wait for its next frame without end (a live
        topic whose camera went quiet) ends that wait, and its iteration, once ``stop`` is set, so Ctrl-C or
        SIGTERM still ends the run. The directors call this before iterating; other sources ignore it."""

    def run_summary(self) -> str | None:
        """One line on what the source itself saw, for the end of a run (a live topic: messages received and
        frames dropped because a newer one came first), or None."""
        return None

    def close(self) -> None:  # noqa: B027 - most sources hold nothing to release
        """Release what the source holds."""

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"
