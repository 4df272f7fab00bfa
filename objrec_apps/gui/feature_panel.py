"""The FeatureDetector's own panel (registered through the panel hook): the generated parameters plus
the target: a thumbnail, its size and keypoints, why the frame on screen found nothing, and Clear target.

It reads the detector by duck typing (``target``, ``clear_target``), so it keeps working if the detector
grows, and shows the generated panel's content alone where these are missing. What the frame on screen gave
comes from that frame's results (``show_results``, fed by the panel column), never from the detector: a
worker may be running it on a newer frame meanwhile, and it keeps no per-frame state.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QPixmap
from PySide6.QtWidgets import QGroupBox, QLabel, QPushButton, QVBoxLayout, QWidget

from objrec_core import Change, Parametrizable, StageResults

from .images import ImageBuffer
from .panels import ParameterPanel, register_panel

THUMBNAIL = 200
HINT = "No target yet: drag a rectangle around a textured object in the original view."


def target_picture(target: Any) -> np.ndarray | None:
    """The stored target image with its selection outlined, or None."""
    image = getattr(target, "image", None)
    if not isinstance(image, np.ndarray):
        return None
    picture = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    roi = getattr(target, "roi", None)
    if roi is not None:
        cv2.rectangle(picture, (roi.x, roi.y), (roi.x + roi.width - 1, roi.y + roi.height - 1), (0, 255, 255), 1)
    return picture


def frame_status(module_id: str, results: StageResults | None) -> str:
    """The status line for the detector ``module_id`` in the frame ``results`` (empty before it has seen
    one): found, with the inlier count its details carry, or the reason its result carries."""
    stage = next((s for s in results.stages if s.id == module_id and s.role == "detector"), None) if results else None
    if stage is None:
        return ""
    objects = stage.objects
    if not objects:
        return f"Last frame: {getattr(objects, 'reason', None) or 'nothing found'}"
    details = getattr(objects, "details", None)
    attempt = details[0] if isinstance(details, tuple) and details else None
    inliers = getattr(attempt, "inlier_count", None)
    found = f"found {len(objects)} copies" if len(objects) > 1 else "found"
    best = "the first with " if len(objects) > 1 else ""
    return f"Last frame: {found}" + (f" ({best}{inliers} inliers)" if inliers is not None else "")


class FeatureDetectorPanel(ParameterPanel):
    """ParameterPanel + the target box. The status line is polled (4 Hz) because it changes per frame,
    and per-frame notifications would flood every observer."""

    def __init__(self, module: Parametrizable, parent: QWidget | None = None) -> None:
        self.target_box = QGroupBox("Target")
        box = QVBoxLayout(self.target_box)
        self.thumbnail = QLabel()
        self.thumbnail.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.info = QLabel(HINT)
        self.info.setWordWrap(True)
        self.status = QLabel()
        self.status.setWordWrap(True)
        self.clear_button = QPushButton("Clear target")
        box.addWidget(self.thumbnail)
        box.addWidget(self.info)
        box.addWidget(self.status)
        box.addWidget(self.clear_button, 0, Qt.AlignmentFlag.AlignRight)
        self._shown_target: Any = None
        self._thumbnail_buffer: ImageBuffer | None = None
        self._results: StageResults | None = None
        super().__init__(module, parent)
        self.layout().insertWidget(0, self.target_box)
        self.clear_button.clicked.connect(self._clear)
        self.timer = QTimer(self)
        self.timer.setInterval(250)
        self.timer.timeout.connect(self.show_status)
        self.timer.start()

    def redraw(self) -> None:
        super().redraw()
        self.show_target()

    def apply_changes(self, changes: Sequence[Change]) -> None:
        super().apply_changes(changes)
        self.show_target()  # a "state" change (a loaded target) or a parameter that recomputes the target

    def show_target(self) -> None:
        target = getattr(self.module, "target", None)
        self.clear_button.setEnabled(target is not None and hasattr(self.module, "clear_target"))
        if target is self._shown_target:
            return
        self._shown_target = target
        picture = target_picture(target)
        if picture is None:
            self.thumbnail.clear()
            self._thumbnail_buffer = None
            self.info.setText(HINT)
            return
        self._thumbnail_buffer = ImageBuffer.from_array(picture)
        pixmap = QPixmap.fromImage(self._thumbnail_buffer.qimage)
        self.thumbnail.setPixmap(pixmap.scaled(THUMBNAIL, THUMBNAIL, Qt.AspectRatioMode.KeepAspectRatio,
                                               Qt.TransformationMode.SmoothTransformation))
        rect = target.rect
        config = getattr(target, "config", None)
        kind = getattr(config, "type", "")
        self.info.setText(f"{rect.width}×{rect.height} px selected at ({rect.x}, {rect.y}) · "
                          f"{len(target)} {kind} keypoints")

    def show_results(self, results: StageResults) -> None:
        """Keep the results of the frame now on screen; the status line shows them at its next poll."""
        self._results = results

    def show_status(self) -> None:
        if not self.isVisible():
            return
        self.status.setText(frame_status(self.module.id, self._results))
        self.show_target()  # a recompute after a parameter change replaces the target without notifying

    def _clear(self) -> None:
        clear = getattr(self.module, "clear_target", None)
        if clear is not None:
            clear()


register_panel("FeatureDetector", FeatureDetectorPanel)
