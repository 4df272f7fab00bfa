"""Ground truth: the labelled objects of some frames of one source, whatever the kind.

A label file is the kind's business (2D: COCO JSON with boxes and polygons; 3D: a file of shapes per frame,
see each kind's ``truth`` module); what it holds is the same everywhere: for some frames of a source, the
objects a person (or the renderer that made the frame) says are there. A frame is found by its index in the
source or by its header stamp (a bag's frames keep their stamps however the recording is windowed), so the
same file scores a folder, a video, a bag or a live recording of the same scene.

A frame that is not in the truth set is not scored at all; a frame that is, with no objects, says "nothing
here" and every detection on it is a false positive.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

#: How a truth set finds its frames: by index in the source, or by header stamp (nanoseconds).
KeyedBy = Literal["index", "stamp"]


@dataclass(frozen=True)
class FrameTruth:
    """The labelled objects of one frame. ``index`` is the frame's index in its source, ``stamp_ns`` its
    header stamp; at least the one the set is keyed by is given. ``objects`` are the kind's truth objects
    (2D: ``objrec2d.truth.TruthObject2D``; 3D: ``objrec3d.truth.TruthShape``), each with a ``name``."""

    index: int | None
    stamp_ns: int | None
    objects: tuple[Any, ...] = ()


@dataclass
class TruthSet:
    """The labelled frames of one source, in order, and the object names they use.

    ``kind`` is the data kind the objects belong to ("2d", "3d"); ``path`` the file it came from (for
    messages), None for a set made in memory (a demo source's own truth, the GUI's label mode).
    """

    kind: str
    frames: list[FrameTruth] = field(default_factory=list)
    keyed_by: KeyedBy = "index"
    path: str | None = None

    def __post_init__(self) -> None:
        self._by_index = {f.index: f for f in self.frames if f.index is not None}
        self._by_stamp = {f.stamp_ns: f for f in self.frames if f.stamp_ns is not None}

    def __len__(self) -> int:
        return len(self.frames)

    def __iter__(self) -> Iterator[FrameTruth]:
        return iter(self.frames)

    @property
    def names(self) -> list[str]:
        """Every object name in the set, sorted."""
        return sorted({o.name for f in self.frames for o in f.objects})

    @property
    def indices(self) -> list[int]:
        """The labelled frames' indices, in order (an index-keyed set only)."""
        return sorted(self._by_index)

    def lookup(self, index: int, stamp_ns: int | None = None) -> FrameTruth | None:
        """The truth of the frame at ``index`` with header stamp ``stamp_ns``, or None (not labelled)."""
        if self.keyed_by == "stamp":
            return self._by_stamp.get(stamp_ns) if stamp_ns is not None else None
        return self._by_index.get(index)

    def add(self, frame: FrameTruth) -> None:
        """Add or replace the truth of one frame (the GUI's label mode, a source writing its own, frame after
        frame): in order at once, the lookups kept up to date, so a long run's truth grows in linear time."""
        old = self.lookup(frame.index if frame.index is not None else -1, frame.stamp_ns)
        if old is not None:
            self.frames.remove(old)
            self._forget(old)
        key = _order(frame)
        if not self.frames or _order(self.frames[-1]) <= key:
            self.frames.append(frame)  # a source's frames come in order
        else:
            bisect.insort(self.frames, frame, key=_order)
        if frame.index is not None:
            self._by_index[frame.index] = frame
        if frame.stamp_ns is not None:
            self._by_stamp[frame.stamp_ns] = frame

    def _forget(self, frame: FrameTruth) -> None:
        if frame.index is not None and self._by_index.get(frame.index) is frame:
            del self._by_index[frame.index]
        if frame.stamp_ns is not None and self._by_stamp.get(frame.stamp_ns) is frame:
            del self._by_stamp[frame.stamp_ns]

    def subset(self, frames: Sequence[FrameTruth]) -> TruthSet:
        """A set of some of these frames (a tuning split), same kind, keying and path."""
        return TruthSet(self.kind, list(frames), self.keyed_by, self.path)


def _order(frame: FrameTruth) -> tuple[int, int]:
    """Where a frame stands in a truth set: by index, then stamp (a frame without one first)."""
    return (frame.index if frame.index is not None else -1, frame.stamp_ns or 0)
