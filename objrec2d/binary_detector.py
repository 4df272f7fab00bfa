"""BinaryDetector: every blob of non-zero pixels with a plausible outline is an object.

A blob that touches the image border is an object cut off by the frame, or the background itself (a filter that
let everything through turns the whole frame into one blob, whose outline is only 2,236 px on a 640x480 frame).
Dropping them lost real objects (three of the 14 candies in smarties.png, the lab's red box from 1 m), so they are
kept by default and say so: their ``truncated`` flag is set, since their outline is the visible part only. The
background is dropped by area instead (``max_area_fraction``); ``border_blobs`` off drops every border blob as
before. When nothing is kept, the result's ``reason`` says which rule dropped the blobs, with numbers to tune by.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from objrec_core import Bool, Float, Ordered
from objrec_core.modules import Detections

from .base import ImageDetector, as_gray
from .messages import DetectedObject2D


@dataclass
class _Dropped:
    """How many blobs each rule dropped, and the value nearest to passing it, for the reason."""

    short: list[float] = field(default_factory=list)
    long: list[float] = field(default_factory=list)
    border: int = 0
    large: list[float] = field(default_factory=list)


class BinaryDetector(ImageDetector):
    """External contours of the non-zero pixels; each whose length (perimeter in pixels) lies within the
    bounds and covers no more than ``max_area_fraction`` of the image becomes an object outlined by its convex
    hull, flagged ``truncated`` where it touches the image border (dropped instead with ``border_blobs`` off).
    Given a colour image it converts it to grey once."""

    # The sliders stop at 5000 px (a 640x480 frame's own outline is 2236 px); a typed value may reach 20000 for
    # big frames. Both share one range, so the two sliders line up and the minimum can follow the maximum.
    min_contour_length = Float(
        40.0, "Shortest outline kept, in pixels; drops specks", min=0.0, max=20000.0, soft_max=5000.0, step=1.0
    )
    max_contour_length = Float(
        5000.0,
        "Longest outline kept, in pixels; drops large blobs (a 640x480 frame's own outline is 2236 px, so this "
        "alone does not drop the background: border_blobs and max_area_fraction do)",
        min=0.0, max=20000.0, soft_max=5000.0, step=1.0,
    )
    length_order = Ordered("min_contour_length", "max_contour_length", why="nothing could ever be found")
    border_blobs = Bool(
        True,
        "Keep blobs that touch the image border (objects cut off by the frame edge), flagged truncated; off, "
        "they are dropped (max_area_fraction drops the whole-frame background either way)",
    )
    max_area_fraction = Float(
        0.9,
        "Largest blob kept, as a share of the image area (its outline's area); drops a background that passed the "
        "filters. 1 keeps every size",
        min=0.0, max=1.0, step=0.01,
    )

    def detect(self, frame: np.ndarray) -> Detections:
        """The kept blobs; when none, the reason is an empty mask, or which rules dropped how many blobs.

        The loop over the blobs does the rules and keeps each hull and flag, nothing else (a busy frame has 70
        of them and each microsecond per blob shows against bare OpenCV: benchmarks/bench_2d.py); the objects
        are made together from them, and what the rules dropped is counted only when nothing was kept, where
        the reason needs it."""
        p = self.params
        lo, hi, keep_border = p.min_contour_length, p.max_contour_length, p.border_blobs
        mask = as_gray(frame)
        height, width = mask.shape
        max_area = p.max_area_fraction * width * height
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        arc_length, bounding_rect, contour_area, convex_hull = (
            cv2.arcLength, cv2.boundingRect, cv2.contourArea, cv2.convexHull)
        hulls: list[np.ndarray] = []
        cut: list[bool] = []
        keep_hull, keep_cut = hulls.append, cut.append
        for contour in contours:
            if not lo <= arc_length(contour, True) <= hi:
                continue
            x, y, w, h = bounding_rect(contour)
            truncated = x == 0 or y == 0 or x + w == width or y + h == height
            if (truncated and not keep_border) or contour_area(contour) > max_area:
                continue
            keep_hull(convex_hull(contour))
            keep_cut(truncated)
        if hulls:
            return Detections(DetectedObject2D.outlined(self.object_name, hulls, cut))
        return Detections((), self._reason(len(contours), self._dropped(contours, p, width, height), p))

    @staticmethod
    def _dropped(contours: Any, p: Any, width: int, height: int) -> _Dropped:
        """What each rule dropped, in the order ``detect`` applies them (only asked when nothing was kept)."""
        dropped = _Dropped()
        max_area = p.max_area_fraction * width * height
        for contour in contours:
            length = cv2.arcLength(contour, True)
            if length < p.min_contour_length:
                dropped.short.append(length)
            elif length > p.max_contour_length:
                dropped.long.append(length)
            else:
                x, y, w, h = cv2.boundingRect(contour)
                if not p.border_blobs and (x == 0 or y == 0 or x + w == width or y + h == height):
                    dropped.border += 1
                elif (area := cv2.contourArea(contour)) > max_area:
                    dropped.large.append(area / (width * height))
        return dropped

    @staticmethod
    def _reason(blobs: int, dropped: _Dropped, p: Any) -> str:
        """Why no blob was kept: each rule with its count and the value nearest to passing it (``p``: the
        frame's parameter snapshot, so the numbers are the ones the frame was judged by)."""
        if blobs == 0:
            return "no blob: the mask has no non-zero pixel (the filters before let nothing through)"
        parts = []
        if dropped.short:
            parts.append(f"{len(dropped.short)} shorter than min_contour_length {p.min_contour_length:g} px "
                         f"(longest {max(dropped.short):.0f} px)")
        if dropped.long:
            parts.append(f"{len(dropped.long)} longer than max_contour_length {p.max_contour_length:g} px "
                         f"(shortest {min(dropped.long):.0f} px)")
        if dropped.border:
            parts.append(f"{dropped.border} touching the image border (border_blobs is off)")
        if dropped.large:
            parts.append(f"{len(dropped.large)} covering more than max_area_fraction {p.max_area_fraction:g} of "
                         f"the image (smallest {min(dropped.large):.0%})")
        plural = "" if blobs == 1 else "s"
        return f"{blobs} blob{plural}, none kept: " + ", ".join(parts)
