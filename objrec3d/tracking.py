"""Identity across frames: an object that stays keeps its ``id``.

A detector finds its objects afresh in every cloud, so nothing in one frame's message says which object of the
last frame it is; a robot that picks one up, or a consumer that draws its trail, needs that. The tracker keeps
what it last saw of each object (its name and shape, centre and size) and matches every new frame against it:

- Only objects of the same name and shape can be the same object, and only when their sizes agree (radius for
  spheres and cylinders, whose boxes grow and shrink with what is visible; the box's half diagonal otherwise)
  and the centre moved at most ``max_shift`` times the object's size. Gating by the object's own size keeps a
  small cylinder from taking over a large one's identity when their paths cross.
- Among the pairs that pass, the matching keeps as many identities as possible and then prefers the smallest
  moves (an optimal assignment on the small matrix of tracks x objects, not nearest first).
- An object that is not seen keeps its identity for ``max_missed`` frames, then is forgotten; a new object
  gets the next number. The same frames in the same order always give the same ids.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .messages import DetectedObject3D

log = logging.getLogger(__name__)

#: Sizes and distances below this (metres) count as this: an empty box still has a scale to compare with.
_SMALLEST = 1e-3


@dataclass
class _Track:
    """What the tracker last saw of one object."""

    id: str
    key: tuple[str, str]
    centre: np.ndarray
    extent: float
    size: float
    missed: int = 0


def _extent(obj: DetectedObject3D) -> float:
    """Half the box's diagonal: how far the object reaches from its centre."""
    box = obj.box
    return max(0.5 * math.sqrt(box.width**2 + box.height**2 + box.depth**2), _SMALLEST)


def _size(obj: DetectedObject3D, extent: float) -> float:
    """The size two sightings of one object must share: the fitted radius where there is one (steady), else
    the extent."""
    return max(obj.radius, _SMALLEST) if obj.radius > 0 else extent


class IdentityTracker:
    """Gives each object of a stream an ``id`` that stays while the object does; one tracker per detector.

    ``max_shift``: how far a centre may move between two sightings, in object sizes (the larger half diagonal of
    the two boxes). ``max_size_ratio``: how much larger one sighting may be than the other. ``max_missed``: the
    frames an unseen object keeps its identity before it is forgotten.
    """

    def __init__(self, max_shift: float = 1.0, max_size_ratio: float = 1.5, max_missed: int = 5) -> None:
        if not (max_shift > 0 and math.isfinite(max_shift)):
            raise ValueError(f"IdentityTracker: max_shift={max_shift!r} must be a positive number of object sizes")
        if not max_size_ratio >= 1:
            raise ValueError(f"IdentityTracker: max_size_ratio={max_size_ratio!r} must be at least 1")
        if max_missed < 0:
            raise ValueError(f"IdentityTracker: max_missed={max_missed!r} must be 0 or more frames")
        self.max_shift = float(max_shift)
        self.max_size_ratio = float(max_size_ratio)
        self.max_missed = int(max_missed)
        self._tracks: list[_Track] = []
        self._next = 1

    def reset(self) -> None:
        """Forget every object and start numbering again: the next frame is the first of a new stream."""
        self._tracks = []
        self._next = 1

    @property
    def tracked(self) -> int:
        """How many objects the tracker remembers (seen now or missed for at most ``max_missed`` frames)."""
        return len(self._tracks)

    def assign(self, objects: Sequence[DetectedObject3D]) -> list[DetectedObject3D]:
        """This frame's objects, in their order, each with the ``id`` of the object it continues or a new one."""
        extents = [_extent(o) for o in objects]
        sizes = [_size(o, e) for o, e in zip(objects, extents, strict=True)]
        centres = [o.center for o in objects]
        keys = [(o.name, o.shape) for o in objects]
        matched = self._match(keys, centres, extents, sizes)
        ids: list[str] = []
        seen: set[str] = set()
        for j, obj in enumerate(objects):
            t = matched.get(j)
            if t is None:
                track = _Track(str(self._next), keys[j], centres[j], extents[j], sizes[j])
                self._next += 1
                self._tracks.append(track)
                log.debug("new object %s: %s %s at %s", track.id, obj.name, obj.shape, np.round(centres[j], 3))
            else:
                track = self._tracks[t]
                track.centre, track.extent, track.size, track.missed = centres[j], extents[j], sizes[j], 0
            seen.add(track.id)
            ids.append(track.id)
        kept = []
        for track in self._tracks:
            if track.id not in seen:
                track.missed += 1
            if track.missed <= self.max_missed:
                kept.append(track)
            else:
                log.debug("object %s forgotten after %d frames unseen", track.id, track.missed)
        self._tracks = kept
        return [dataclasses.replace(o, id=i) for o, i in zip(objects, ids, strict=True)]

    def _match(self, keys: list[tuple[str, str]], centres: list[np.ndarray], extents: list[float],
               sizes: list[float]) -> dict[int, int]:
        """Object index -> track index for the pairs the gates allow, as many as possible, smallest moves first."""
        if not self._tracks or not keys:
            return {}
        tracks = self._tracks
        same_kind = np.array([[key == track.key for key in keys] for track in tracks])
        track_sizes = np.array([track.size for track in tracks])[:, None]
        ratio = np.maximum(track_sizes, sizes) / np.minimum(track_sizes, sizes)
        moved = np.linalg.norm(np.asarray(centres)[None] - np.array([t.centre for t in tracks])[:, None], axis=2)
        shift = moved / np.maximum(np.array([t.extent for t in tracks])[:, None], extents)
        allowed = same_kind & (ratio <= self.max_size_ratio) & (shift <= self.max_shift)
        if not allowed.any():
            return {}
        cost = shift + np.log(ratio)
        # A refused pair costs more than all allowed ones together: the assignment first keeps as many
        # identities as it can, then moves the least.
        refused = 1.0 + float(cost[allowed].sum())
        pairs = min_cost_assignment(np.where(allowed, cost, refused))
        return {j: i for i, j in pairs if allowed[i, j]}


def min_cost_assignment(cost: np.ndarray) -> list[tuple[int, int]]:
    """The (row, column) pairs, one per row or per column whichever are fewer, of least total cost.

    The Hungarian method with potentials (Kuhn-Munkres, O(n^2 m)): exact like ``scipy.optimize.
    linear_sum_assignment``, whose import alone costs more than matching the few dozen objects of a frame.
    """
    cost = np.asarray(cost, dtype=np.float64)
    if cost.shape[0] > cost.shape[1]:
        return [(i, j) for j, i in min_cost_assignment(cost.T)]
    n, m = cost.shape
    a = np.zeros((n + 1, m + 1))
    a[1:, 1:] = cost
    u, v = np.zeros(n + 1), np.zeros(m + 1)
    row_of = np.zeros(m + 1, dtype=np.intp)  # column j (1-based) -> its row (1-based), 0 when free
    way = np.zeros(m + 1, dtype=np.intp)
    for i in range(1, n + 1):
        row_of[0], j0 = i, 0
        slack = np.full(m + 1, np.inf)
        used = np.zeros(m + 1, dtype=bool)
        while True:
            used[j0] = True
            i0 = row_of[j0]
            free = ~used
            reduced = a[i0] - u[i0] - v
            better = free & (reduced < slack)
            slack[better] = reduced[better]
            way[better] = j0
            candidates = np.where(free, slack, np.inf)
            j1 = int(np.argmin(candidates))
            delta = candidates[j1]
            u[row_of[used]] += delta
            v[used] -= delta
            slack[free] -= delta
            j0 = j1
            if row_of[j0] == 0:
                break
        while j0:
            j1 = way[j0]
            row_of[j0] = row_of[j1]
            j0 = j1
    return sorted((int(row_of[j]) - 1, j - 1) for j in range(1, m + 1) if row_of[j])
