"""The narrowest passage between two places: why an inflated costmap has no path where the map has one.

A doorway that the map shows open is closed to the planner once obstacles are inflated by more than half its
width. When a plan fails because the goal lies in another region, the question a student asks is "which door,
and by how much?". The answer is the bottleneck of the widest way: the largest clearance ``c`` such that the
cells with at least ``c`` still connect start and goal (found by bisection over the clearances present, one
connected-components pass each, so a failure explains itself in a few passes over the map), and, among the
cells at exactly that clearance, the one nearest to both sides it separates.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .grid_distance import distance_to_zero


@dataclass(frozen=True)
class Passage:
    """The bottleneck of the widest way between two cells: a flat cell index and its clearance (metres)."""

    cell: int
    clearance: float

    def width(self, resolution: float) -> float:
        """Wall-to-wall width of a passage whose middle cell has this clearance: twice the clearance, plus the
        half cell a middle cell lacks when the passage is an even number of cells wide (rounded to a cell)."""
        return round((2.0 * self.clearance + 0.5 * resolution) / resolution) * resolution


def _connected(free: np.ndarray, a: int, b: int) -> tuple[bool, np.ndarray]:
    _, labels = cv2.connectedComponents(free.astype(np.uint8), connectivity=4)
    flat = labels.ravel()
    return bool(flat[a] != 0 and flat[a] == flat[b]), labels


def narrowest_passage(clear: np.ndarray, start: int, goal: int) -> Passage | None:
    """The bottleneck between flat cells ``start`` and ``goal`` of the clearance grid ``clear`` (metres to the
    nearest obstacle surface, 4-connected as the planner's regions are), or None when only obstacles (clearance
    0 or less) separate them."""
    flat = clear.ravel()
    top = min(flat[start], flat[goal])
    levels = np.unique(flat[(flat > 0.0) & (flat <= top)])
    if not len(levels) or not _connected(clear >= levels[0], start, goal)[0]:
        return None
    lo, hi = 0, len(levels)  # levels[lo] connects; levels[hi] (if any) does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _connected(clear >= levels[mid], start, goal)[0]:
            lo = mid
        else:
            hi = mid
    level = float(levels[lo])
    _, joined = _connected(clear >= level, start, goal)
    way = joined.ravel() == joined.ravel()[start]
    candidates = np.flatnonzero(way & (flat < (levels[hi] if hi < len(levels) else np.inf)))
    if hi >= len(levels) or not len(candidates):
        return Passage(int(start if flat[start] <= flat[goal] else goal), level)
    # Split at the next level up: the bottleneck sits between the start's side and the goal's side.
    _, split = _connected(clear >= levels[hi], start, goal)
    side_a = split == split.ravel()[start]
    side_b = split == split.ravel()[goal]
    to_a = distance_to_zero((~side_a).astype(np.uint8)).ravel()
    to_b = distance_to_zero((~side_b).astype(np.uint8)).ravel()
    best = candidates[np.argmin(to_a[candidates] + to_b[candidates])]
    return Passage(int(best), level)
