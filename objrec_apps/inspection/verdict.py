"""What a visit found, and whether each expected object is present, absent or moved.

Frames taken at several headings see the same object more than once: sightings of one name closer than
``MERGE_RADIUS`` are one object, placed at their mean. An expected object is ``present`` when an object
of its label was found within its tolerance of where the world file puts it, ``moved`` when the nearest
one is farther, ``absent`` when none was found, and ``not_checked`` when no detection that looks for its
label ran at the visit (the goal was not reached, or the pose's tasks do not look for it), with the reason.

A 2D detection is placed by the depth under its outline: a point on the face the camera sees, up to half the
object's depth in front of its centre. Before it is compared, it is lifted to the centre along the camera's
line of sight by the expected object's known size (:func:`lift_to_centre`), so a box moved 0.35 m toward the
camera, within a 0.5 m tolerance, reads present rather than "moved, 0.54 m".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from navigation.world import World, WorldObject

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
    camera: tuple[float, float] | None = None  # mean camera position of the sightings (map, metres)
    lifted: float = 0.0  # metres moved from the seen face to the object's centre (2D detections)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "x": round(self.x, 3), "y": round(self.y, 3), "z": round(self.z, 3),
                "method": self.method, "sightings": self.sightings, "lifted_m": round(self.lifted, 3)}


@dataclass(frozen=True)
class Verdict:
    name: str
    label: str
    status: str
    expected: tuple[float, float, float]
    tolerance: float
    found: Found | None = None
    error: float | None = None  # horizontal distance (metres) between found and expected
    reason: str = ""  # why it was not checked

    def with_reason(self, reason: str) -> Verdict:
        return replace(self, reason=reason)

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, "status": self.status,
                "expected": {"x": round(self.expected[0], 3), "y": round(self.expected[1], 3),
                             "z": round(self.expected[2], 3)},
                "tolerance_m": self.tolerance,
                "found": self.found.as_dict() if self.found else None,
                "error_m": None if self.error is None else round(self.error, 3), "reason": self.reason}


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
    return [Found(g[0].name, _mean(g, "x"), _mean(g, "y"), _mean(g, "z"), g[0].method, len(g), _viewpoint(g))
            for g in groups]


def _viewpoint(group: Sequence[Sighting]) -> tuple[float, float] | None:
    """Where the camera stood for a group's sightings (their mean), when they say."""
    seen = [(s.camera_x, s.camera_y) for s in group if s.camera_x is not None and s.camera_y is not None]
    if not seen:
        return None
    return (sum(x for x, _ in seen) / len(seen), sum(y for _, y in seen) / len(seen))


def lift_to_centre(found: Found, thing: WorldObject) -> Found:
    """A 2D detection (its seen face) moved along the line of sight to where the centre of ``thing`` would be.

    The depth behind the face is measured on the expected object's own outline, entered along the same line
    of sight; a 3D box detection is already a centre, and a sighting without its camera cannot be lifted.
    """
    if found.method != "polygon" or found.camera is None:
        return found
    dx, dy = found.x - found.camera[0], found.y - found.camera[1]
    norm = math.hypot(dx, dy)
    if norm < 1e-9:
        return found
    ux, uy = dx / norm, dy / norm
    outline = thing.footprint()
    back = outline.radius + 1.0  # a start outside the outline, on the camera's side
    entry = float(outline.ray_distances(outline.x - back * ux, outline.y - back * uy,
                                        np.array([ux]), np.array([uy]))[0])
    if not math.isfinite(entry):
        return found
    depth = max(0.0, back - entry)
    return replace(found, x=found.x + depth * ux, y=found.y + depth * uy, lifted=depth)


def _mean(group: Sequence[Sighting], axis: str) -> float:
    return sum(getattr(s, axis) for s in group) / len(group)


def judge(expected: Sequence[Expected], found: Sequence[Found], world: World, looked_for: set[str]) -> list[Verdict]:
    """A verdict for each expected object; ``world`` is the world file (where the objects should be)."""
    verdicts = []
    for e in expected:
        where = centre_of(world, e.name)
        if e.label not in looked_for:
            verdicts.append(Verdict(e.name, e.label, NOT_CHECKED, where, e.tolerance))
            continue
        candidates = [f for f in found if f.name == e.label]
        if not candidates:
            verdicts.append(Verdict(e.name, e.label, ABSENT, where, e.tolerance))
            continue
        thing = next(o for o in world.objects if o.name == e.name)
        candidates = [lift_to_centre(f, thing) for f in candidates]
        best = min(candidates, key=lambda f: math.hypot(f.x - where[0], f.y - where[1]))
        error = math.hypot(best.x - where[0], best.y - where[1])
        status = PRESENT if error <= e.tolerance else MOVED
        verdicts.append(Verdict(e.name, e.label, status, where, e.tolerance, best, error))
    return verdicts


def centre_of(world: World, name: str) -> tuple[float, float, float]:
    """The middle of a world object: where a detector should place it."""
    x, y, z = next(o for o in world.objects if o.name == name).centre
    return (float(x), float(y), float(z))
