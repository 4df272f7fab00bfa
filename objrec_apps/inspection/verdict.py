"""What a visit found, and whether each expected object is present, absent or moved.

Frames taken at several headings see the same object more than once: sightings of one name closer than
``MERGE_RADIUS`` are one object, placed at their mean. An expected object is ``present`` when an object
of its label was found within its tolerance of where the world file puts it, ``moved`` when the nearest
one is farther, ``absent`` when none was found, and ``not_checked`` when no detection that looks for its
label ran at the visit (the goal was not reached, or the pose's tasks do not look for it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from navigation.world import World

from .locate import Sighting
from .mission import Expected

#: Sightings of one name nearer than this (metres) are the same object.
MERGE_RADIUS = 0.4

PRESENT, ABSENT, MOVED, NOT_CHECKED = "present", "absent", "moved", "not_checked"


@dataclass(frozen=True)
class Found:
    """One object found at a visit: its name, map position (mean of its sightings) and how it was placed."""

    name: str
    x: float
    y: float
    z: float
    method: str
    sightings: int

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "x": round(self.x, 3), "y": round(self.y, 3), "z": round(self.z, 3),
                "method": self.method, "sightings": self.sightings}


@dataclass(frozen=True)
class Verdict:
    name: str
    label: str
    status: str
    expected: tuple[float, float, float]
    tolerance: float
    found: Found | None = None
    error: float | None = None  # horizontal distance (metres) between found and expected

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, "status": self.status,
                "expected": {"x": round(self.expected[0], 3), "y": round(self.expected[1], 3),
                             "z": round(self.expected[2], 3)},
                "tolerance_m": self.tolerance,
                "found": self.found.as_dict() if self.found else None,
                "error_m": None if self.error is None else round(self.error, 3)}


def merge(sightings: Sequence[Sighting], radius: float = MERGE_RADIUS) -> list[Found]:
    """Group sightings by name and nearness (greedy, in order); each group becomes one :class:`Found`."""
    groups: list[list[Sighting]] = []
    for s in sightings:
        for group in groups:
            g = group[0]
            if g.name == s.name and math.hypot(_mean(group, "x") - s.x, _mean(group, "y") - s.y) < radius:
                group.append(s)
                break
        else:
            groups.append([s])
    return [Found(g[0].name, _mean(g, "x"), _mean(g, "y"), _mean(g, "z"), g[0].method, len(g)) for g in groups]


def _mean(group: Sequence[Sighting], axis: str) -> float:
    return sum(getattr(s, axis) for s in group) / len(group)


def judge(expected: Sequence[Expected], found: Sequence[Found], world: World, looked_for: set[str]) -> list[Verdict]:
    """A verdict for each expected object; ``world`` is the world file (where the objects should be)."""
    verdicts = []
    for e in expected:
        where = _centre(world, e.name)
        if e.label not in looked_for:
            verdicts.append(Verdict(e.name, e.label, NOT_CHECKED, where, e.tolerance))
            continue
        candidates = [f for f in found if f.name == e.label]
        if not candidates:
            verdicts.append(Verdict(e.name, e.label, ABSENT, where, e.tolerance))
            continue
        best = min(candidates, key=lambda f: math.hypot(f.x - where[0], f.y - where[1]))
        error = math.hypot(best.x - where[0], best.y - where[1])
        status = PRESENT if error <= e.tolerance else MOVED
        verdicts.append(Verdict(e.name, e.label, status, where, e.tolerance, best, error))
    return verdicts


def _centre(world: World, name: str) -> tuple[float, float, float]:
    """The middle of a world object: where a detector should place it."""
    x, y, z = next(o for o in world.objects if o.name == name).centre
    return (float(x), float(y), float(z))
