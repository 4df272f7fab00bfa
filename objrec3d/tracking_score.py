"""Tracking figures over a sequence of frames: identity switches (CLEAR MOT) and IDF1 (Ristani et al. 2016).

A truth object's identity is its ``id`` in the label file, else its name; a detection's is the ``id`` the 3D
detector's tracker gives it (``objrec3d.tracking``). A truth object and a detection *correspond* in a frame
when the detection's centre lies within the truth's gate (the same gate as the detection matching).

- **IDF1**: one global one-to-one assignment between truth identities and detection ids that maximises the
  frames where assigned pairs correspond (``objrec3d.tracking.min_cost_assignment``, exact like SciPy's
  ``linear_sum_assignment``). ``IDTP`` is that number of frames, ``IDFN`` the truth sightings left
  (``truth sightings - IDTP``), ``IDFP`` the detections left (``detections - IDTP``);
  ``IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN)``, ``IDP = IDTP / detections``,
  ``IDR = IDTP / truth sightings``. It says how much of the time each object carries its one right id.
- **Identity switches**: frame by frame, a truth object keeps the detection id it had where that id is still
  within its gate; the others are matched by the smallest centre distances. A switch is counted each time a
  truth object is matched to an id other than the one it was last matched to (however many frames ago).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .tracking import min_cost_assignment

#: One truth sighting in a frame: identity, centre, gate (metres).
TruthSighting = tuple[str, tuple[float, float, float], float]
#: One detection in a frame: its id and centre.
Detection = tuple[str, tuple[float, float, float]]


@dataclass(frozen=True)
class TrackingFigures:
    """The tracking figures of a sequence (see the module's docstring)."""

    idf1: float
    idp: float
    idr: float
    idtp: int
    idfp: int
    idfn: int
    id_switches: int
    truth_tracks: int
    tracks: int

    def to_dict(self) -> dict[str, Any]:
        return dict(vars(self))


class TrackingScore:
    """Fed one frame at a time with the truth sightings and the tracked detections."""

    def __init__(self) -> None:
        self._truth_ids: dict[str, int] = {}
        self._track_ids: dict[str, int] = {}
        self._together: dict[tuple[int, int], int] = {}
        self._truth_count = 0
        self._detection_count = 0
        self._last: dict[str, str] = {}
        self.id_switches = 0

    def add(self, truths: Sequence[TruthSighting], detections: Sequence[Detection]) -> None:
        self._truth_count += len(truths)
        self._detection_count += len(detections)
        for name, _, _ in truths:
            self._truth_ids.setdefault(name, len(self._truth_ids))
        for ident, _ in detections:
            self._track_ids.setdefault(ident, len(self._track_ids))
        if not truths or not detections:
            return
        t = np.array([c for _, c, _ in truths], dtype=float)
        d = np.array([c for _, c in detections], dtype=float)
        distance = np.linalg.norm(t[:, None, :] - d[None, :, :], axis=2)
        close = distance <= np.array([g for _, _, g in truths])[:, None]
        seen: set[tuple[int, int]] = set()
        for i, j in zip(*np.nonzero(close), strict=True):
            key = (self._truth_ids[truths[i][0]], self._track_ids[detections[j][0]])
            if key not in seen:  # a pair corresponds at most once per frame
                seen.add(key)
                self._together[key] = self._together.get(key, 0) + 1
        # CLEAR MOT: keep last frame's correspondences that still hold, then match the rest by distance
        matched: dict[int, int] = {}
        for i, (name, _, _) in enumerate(truths):
            previous = self._last.get(name)
            for j, (ident, _) in enumerate(detections):
                if ident == previous and close[i, j] and j not in matched.values():
                    matched[i] = j
                    break
        rest_t = [i for i in range(len(truths)) if i not in matched]
        rest_d = [j for j in range(len(detections)) if j not in matched.values()]
        if rest_t and rest_d:
            sub = distance[np.ix_(rest_t, rest_d)]
            cost = np.where(close[np.ix_(rest_t, rest_d)], sub, 1.0e9)
            for r, c in min_cost_assignment(cost):
                if cost[r, c] < 1.0e9:
                    matched[rest_t[r]] = rest_d[c]
        for i, j in matched.items():
            name, ident = truths[i][0], detections[j][0]
            if name in self._last and self._last[name] != ident:
                self.id_switches += 1
            self._last[name] = ident

    def figures(self) -> TrackingFigures:
        idtp = 0
        if self._together:
            table = np.zeros((len(self._truth_ids), len(self._track_ids)))
            for (i, j), n in self._together.items():
                table[i, j] = n
            idtp = int(sum(table[i, j] for i, j in min_cost_assignment(-table)))
        idfn, idfp = self._truth_count - idtp, self._detection_count - idtp
        total = 2 * idtp + idfp + idfn
        return TrackingFigures(
            idf1=2 * idtp / total if total else 1.0,
            idp=idtp / self._detection_count if self._detection_count else 1.0,
            idr=idtp / self._truth_count if self._truth_count else 1.0,
            idtp=idtp, idfp=idfp, idfn=idfn, id_switches=self.id_switches,
            truth_tracks=len(self._truth_ids), tracks=len(self._track_ids))
