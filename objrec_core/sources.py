"""Frames and frame sources, independent of what a frame holds (an image, a point cloud)."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any


class SourceError(RuntimeError):
    """A source that cannot be opened, fails mid-stream or yields a corrupt frame; says which and why."""


@dataclass
class Frame:
    """One input frame: its data, when it was taken, its number, and ground truth where the source knows it."""

    data: Any
    stamp: float = field(default_factory=time.time)
    index: int = 0
    source: str = ""
    truth: Any = None


class FrameSource(ABC):
    """An iterable of frames that knows its name and, where it can, its length.

    Sources are context managers; ``close`` releases a camera or file. A source that ends simply stops
    iterating; one that fails raises SourceError naming itself.
    """

    #: How the user named this source (a path, ``camera:0``, ``demo``).
    name: str = ""

    def __len__(self) -> int:
        """Number of frames, where known (files, folders); raises TypeError for endless sources."""
        length = self.length
        if length is None:
            raise TypeError(f"source {self.name!r} has no known length")
        return length

    @property
    def length(self) -> int | None:
        return None

    @abstractmethod
    def __iter__(self) -> Iterator[Frame]: ...

    def close(self) -> None:  # noqa: B027 - most sources hold nothing to release
        """Release what the source holds."""

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"
