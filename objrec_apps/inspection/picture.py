"""The picture of an inspection: the map, the route driven, the goals, and the verdict on each object.

Objects of the world file are drawn as grey outlines where they should be; what was found is a filled
dot at its map position (green when it is an expected object present, orange when moved, with an arrow
from where it should have been, blue when nobody expected it); an expected object not found is a red
cross, one not checked a grey question mark. Obstacles the map does not know are brown outlines, a moving one
with the path it went along (dashed). A goal whose visit aborted is a red goal with a cross; a collision is
a magenta star (never the red cross of a missing object). Keepout and speed zones (``--keepout-mask``,
``--speed-mask``) are tinted red and amber, as on the patrol's picture. Every mark has its entry in the legend
(a zone's only when there is one), which wraps onto more rows on a narrow map rather than running off the
picture.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from navigation.geometry import Pose2D
from navigation.map_view import MapView
from navigation.maps import OccupancyMap
from navigation.render import draw_dashed, first_passes, zone_legend
from navigation.world import World, WorldObject
from strictio.shown import drawable

from .report import InspectionReport
from .verdict import ABSENT, MOVED, NOT_CHECKED, PRESENT

ROUTE = (200, 110, 20)
GOAL = (120, 60, 60)
OUTLINE = (150, 150, 150)
OBSTACLE = (40, 90, 140)
COLOURS = {PRESENT: (40, 160, 40), MOVED: (0, 140, 255), ABSENT: (30, 30, 220), NOT_CHECKED: (120, 120, 120)}
UNEXPECTED = (200, 80, 20)
ABORTED_GOAL = (30, 30, 220)
COLLISION = (200, 0, 200)
UNCHECKED = (120, 120, 120)
#: The legend, in order: (label, colour, mark).
LEGEND = [("present", COLOURS[PRESENT], "dot"), ("moved", COLOURS[MOVED], "dot"),
          ("missing", COLOURS[ABSENT], "cross"), ("not checked", UNCHECKED, "question"),
          ("not expected", UNEXPECTED, "dot"), ("expected place", OUTLINE, "ring"),
          ("obstacle not in the map", OBSTACLE, "ring"), ("moving obstacle's path", OBSTACLE, "dashed"),
          ("route", ROUTE, "line"), ("goal", GOAL, "goal"), ("aborted goal", ABORTED_GOAL, "aborted"),
          ("collision", COLLISION, "star")]
TEXT = (40, 40, 40)
FONT = cv2.FONT_HERSHEY_SIMPLEX


def _text(img: np.ndarray, text: str, at: tuple[int, int], colour: tuple[int, int, int], scale: float) -> None:
    """A label with a white halo; one that would run off the right edge is moved left to fit."""
    width = cv2.getTextSize(drawable(text), FONT, scale, 1)[0][0]
    at = (max(2, min(at[0], img.shape[1] - width - 4)), at[1])
    cv2.putText(img, drawable(text), at, FONT, scale, (255, 255, 255), 3, cv2.LINE_AA)
    cv2.putText(img, drawable(text), at, FONT, scale, colour, 1, cv2.LINE_AA)


def _outline(view: MapView, img: np.ndarray, thing: WorldObject, colour: tuple[int, int, int]) -> None:
    fp = thing.footprint()
    if fp.is_circle:
        cv2.circle(img, view.px(fp.x, fp.y), max(2, round(fp.radius * view.px_per_m)), colour, 1, cv2.LINE_AA)
    else:
        pts = np.array([view.px(x, y) for x, y in fp.corners()], np.int32)
        cv2.polylines(img, [pts.reshape(-1, 1, 2)], True, colour, 1, cv2.LINE_AA)


def draw_inspection(occ_map: OccupancyMap, reference: World, simulated: World, report: InspectionReport,
                    trajectory: Sequence[tuple[float, float, float, float]], goals: Sequence[Pose2D],
                    collisions: Sequence[tuple[float, float]] = (), caption: str = "", max_side: int = 1000,
                    zones: np.ndarray | None = None) -> np.ndarray:
    """The picture; ``zones`` is the keepout and speed zones' layer
    (:func:`navigation.nav_params.apply_to_simulation` returns it), None when there are none."""
    view = MapView.of_known(occ_map, max_side)
    if zones is not None:
        view.tint(zones)
    img = view.image
    fs = max(0.4, min(img.shape[:2]) / 1500.0)
    for obj in reference.objects:
        _outline(view, img, obj, OUTLINE)
        p = view.px(obj.x, obj.y)
        _text(img, obj.name, (p[0] + 8, p[1] + 18), OUTLINE, fs * 0.9)
    end = trajectory[-1][0] if trajectory else 0.0
    for obstacle in simulated.obstacles:
        body = obstacle.body if hasattr(obstacle, "body") else obstacle
        if hasattr(obstacle, "position_at"):
            for run in first_passes([view.px(*obstacle.position_at(t)) for t in np.linspace(0.0, end, 400)]):
                draw_dashed(img, run, OBSTACLE, thickness=2, dash=8.0, gap=10.0)
        _outline(view, img, body, OBSTACLE)
        p = view.px(body.x, body.y)
        _text(img, obstacle.name, (p[0] + 8, p[1] + 4), OBSTACLE, fs * 0.9)
    if len(trajectory) >= 2:
        pts = np.array([view.px(x, y) for _, x, y, _ in trajectory[:: max(1, len(trajectory) // 4000)]], np.int32)
        cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, ROUTE, 2, cv2.LINE_AA)
    aborted = {rec["index"] for rec in report.visits if rec["goal_status"] == "ABORTED"}
    for i, g in enumerate(goals):
        p = view.px(g.x, g.y)
        tip = view.px(g.x + 0.3 * math.cos(g.yaw), g.y + 0.3 * math.sin(g.yaw))
        colour = ABORTED_GOAL if i in aborted else GOAL
        cv2.circle(img, p, 4, colour, 1, cv2.LINE_AA)
        cv2.arrowedLine(img, p, tip, colour, 1, cv2.LINE_AA, tipLength=0.35)
        if i in aborted:
            cv2.drawMarker(img, p, colour, cv2.MARKER_TILTED_CROSS, 12, 2)
        _text(img, f"{i} aborted" if i in aborted else str(i), (p[0] - 14, p[1] - 6), colour, fs)
    expected_labels = {v.label for _, v in report.objects.values()}
    for _, found in report.found:
        if found.name not in expected_labels:
            p = view.px(found.x, found.y)
            cv2.circle(img, p, 6, UNEXPECTED, -1, cv2.LINE_AA)
            _text(img, found.name, (p[0] + 8, p[1] - 8), UNEXPECTED, fs)
    size = max(6, round(0.12 * view.px_per_m))
    for name, (_, verdict) in report.objects.items():
        colour = COLOURS.get(verdict.status)
        if colour is None:
            continue
        e = view.px(verdict.expected[0], verdict.expected[1])
        if verdict.status == NOT_CHECKED:
            _text(img, "?", (e[0] - 5, e[1] + 6), colour, fs * 1.6)
            _text(img, "not checked", (e[0] + 8, e[1] + 18 + round(24 * fs / 0.6)), colour, fs)
            continue
        if verdict.status == ABSENT:
            cv2.line(img, (e[0] - size, e[1] - size), (e[0] + size, e[1] + size), colour, 3, cv2.LINE_AA)
            cv2.line(img, (e[0] - size, e[1] + size), (e[0] + size, e[1] - size), colour, 3, cv2.LINE_AA)
            _text(img, f"{name} missing", (e[0] + size + 4, e[1] - 4), colour, fs)
            continue
        assert verdict.found is not None
        f = view.px(verdict.found.x, verdict.found.y)
        if verdict.status == MOVED:
            cv2.arrowedLine(img, e, f, colour, 2, cv2.LINE_AA, tipLength=0.15)
            _text(img, f"{name} moved", (f[0] + 8, f[1] - 8), colour, fs)
        cv2.circle(img, f, 6, colour, -1, cv2.LINE_AA)
    for x, y in collisions:
        cv2.drawMarker(img, view.px(x, y), COLLISION, cv2.MARKER_STAR, 16, 2)
    legend = LEGEND + [(label, colour, "patch") for label, colour in zone_legend(zones)]
    return np.vstack([_band(img.shape[1], caption, fs, legend), img])


def _mark(band: np.ndarray, x: int, y: int, colour: tuple[int, int, int], mark: str, fs: float) -> None:
    """One legend symbol, drawn as on the map, left of its label at (x, y)."""
    c = (x + 8, y - 5)
    if mark == "dot":
        cv2.circle(band, c, 6, colour, -1, cv2.LINE_AA)
    elif mark == "cross":
        cv2.drawMarker(band, c, colour, cv2.MARKER_TILTED_CROSS, 14, 3)
    elif mark == "ring":
        cv2.circle(band, c, 6, colour, 1, cv2.LINE_AA)
    elif mark == "question":
        cv2.putText(band, "?", (x + 3, y + 1), FONT, fs * 1.4, colour, 2, cv2.LINE_AA)
    elif mark == "dashed":
        for k in (0, 10):  # two dashes as on the map
            cv2.line(band, (x + k, y - 5), (x + k + 5, y - 5), colour, 2, cv2.LINE_AA)
    elif mark in ("goal", "aborted"):
        cv2.circle(band, (x + 4, y - 5), 4, colour, 1, cv2.LINE_AA)
        cv2.arrowedLine(band, (x + 4, y - 5), (x + 17, y - 5), colour, 1, cv2.LINE_AA, tipLength=0.35)
        if mark == "aborted":
            cv2.drawMarker(band, (x + 4, y - 5), colour, cv2.MARKER_TILTED_CROSS, 12, 2)
    elif mark == "star":
        cv2.drawMarker(band, c, colour, cv2.MARKER_STAR, 16, 2)
    elif mark == "patch":
        cv2.rectangle(band, (x + 1, y - 12), (x + 15, y + 2), colour, -1)
    else:
        cv2.line(band, (x, y - 5), (x + 16, y - 5), colour, 2, cv2.LINE_AA)


def _band(width: int, caption: str, fs: float,
          legend: Sequence[tuple[str, tuple[int, int, int], str]] = tuple(LEGEND)) -> np.ndarray:
    """A white strip above the map: the caption, then a legend of the marks, on as many rows as the width needs."""
    line = round(30 * fs / 0.6)
    captions = caption.splitlines()
    placed: list[tuple[int, int, str, tuple[int, int, int], str]] = []
    x, row = 8, 0
    for label, colour, mark in legend:
        w = 20 + cv2.getTextSize(drawable(label), FONT, fs, 1)[0][0]
        if x > 8 and x + w > width - 8:
            x, row = 8, row + 1
        placed.append((x, row, label, colour, mark))
        x += w + 18
    band = np.full((line * (len(captions) + row + 1) + 8, width, 3), 255, np.uint8)
    for k, text in enumerate(captions):
        cv2.putText(band, drawable(text), (8, line * (k + 1) - 6), FONT, fs * 1.1, TEXT, 1, cv2.LINE_AA)
    for x, row, label, colour, mark in placed:
        y = line * (len(captions) + row + 1) - 6
        _mark(band, x, y, colour, mark, fs)
        cv2.putText(band, drawable(label), (x + 20, y), FONT, fs, TEXT, 1, cv2.LINE_AA)
    return band
