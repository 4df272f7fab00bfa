"""Where the 3D view writes the names of its detections: two detections close together on screen (a cylinder
beside a sphere, both a few centimetres wide seen from a metre away) would write one name over the other, and
a detection near the view's edge would have its name cut off."""

from __future__ import annotations

from collections.abc import Sequence

from PySide6.QtCore import QRectF

#: Pixels left between a label and the one it was moved below.
GAP = 1.0


def place_labels(anchors: Sequence[tuple[float, float]], sizes: Sequence[tuple[float, float]],
                 width: float, height: float) -> list[QRectF]:
    """The rectangle of each label, in order: a label wants its bottom-left corner at its anchor; it is kept
    inside the ``width`` x ``height`` view and moved down below every earlier label it would overlap, so an
    earlier (lower-numbered) detection's name keeps its place."""
    placed: list[QRectF] = []
    for (x, y), (w, h) in zip(anchors, sizes, strict=True):
        rect = QRectF(min(max(0.0, x), max(0.0, width - w)), min(max(0.0, y - h), max(0.0, height - h)), w, h)
        moved = True
        while moved:  # the top only grows, past a finite set of bottoms: this ends
            moved = False
            for other in placed:
                if rect.intersects(other):
                    rect.moveTop(other.bottom() + GAP)
                    moved = True
        placed.append(rect)
    return placed
