"""CloudView: the interactive point-cloud view (rotate, zoom, pan, reset) with detected boxes.

It paints the software renderer's image (``cloud_render``) and draws each detected object's box (its
``Outline`` from the data kind) and a small coordinate frame at its centre with QPainter on top, so it needs
no OpenGL and works offscreen.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from PySide6.QtCore import QPointF, QRectF, QSize, Qt, Signal
from PySide6.QtGui import QColor, QFont, QKeyEvent, QMouseEvent, QPainter, QPaintEvent, QPen, QWheelEvent
from PySide6.QtWidgets import QSizePolicy, QWidget

from objrec_core import Outline

from .cloud_render import NEAR, CloudScene, OrbitCamera, layer_colour, render
from .images import ImageBuffer, rgb_qimage

BOX_COLOUR = QColor(255, 255, 0)
AXIS_COLOURS = (QColor(255, 60, 60), QColor(60, 255, 60), QColor(80, 140, 255))
#: Radians per pixel of mouse drag.
ROTATE_SPEED = 0.008
#: Corner pairs joined by the box's twelve edges (corner i: the signs of bits 2, 1, 0 along local x, y, z).
BOX_EDGES = [(i, i ^ bit) for i in range(8) for bit in (1, 2, 4) if i < i ^ bit]


def box_frame(corners: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Centre (3), local axes (3 x 3, one unit vector per row: x, y, z) and side lengths (3) of an oriented
    box given by its eight corners as ``Kind.outlines`` gives them; None when they are not finite."""
    box = np.asarray(corners, dtype=np.float64)
    if box.shape != (8, 3) or not np.isfinite(box).all():
        return None
    edges = np.stack([box[4] - box[0], box[2] - box[0], box[1] - box[0]])  # along local x, y and z
    sides = np.linalg.norm(edges, axis=1)
    axes = np.divide(edges, sides[:, None], out=np.eye(3), where=sides[:, None] > 0)
    return box.mean(axis=0), axes, sides


class CloudView(QWidget):
    """The 3D view. Left drag rotates, right or middle drag (or Shift + left) pans, the wheel zooms,
    a double click or R resets to the sensor's view of the whole cloud."""

    viewChanged = Signal()  # noqa: N815 - Qt's signal naming

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.camera = OrbitCamera()
        self.scene = CloudScene()
        #: One outline per detected object, in the detection list's order (None: nothing to draw).
        self.outlines: list[Outline | None] = []
        self.point_size = 1
        self.hidden: frozenset[int] = frozenset()
        self._fitted = False
        self._cache: tuple[Any, ImageBuffer] | None = None
        self._drag: tuple[QPointF, Qt.MouseButton, Qt.KeyboardModifier] | None = None
        self.setMinimumSize(320, 240)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)
        self.setAttribute(Qt.WidgetAttribute.WA_OpaquePaintEvent)
        self.setToolTip("Drag: rotate · right drag or Shift+drag: pan · wheel: zoom · double click or R: reset")

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt override
        return QSize(640, 480)

    # -- content --------------------------------------------------------------------------------------
    def set_scene(self, scene: CloudScene, outlines: Sequence[Outline | None] = ()) -> None:
        """Show a new frame's layers and its detections' outlines (numbered in order); the view fits itself to
        the first cloud it gets."""
        self.scene = scene
        self.outlines = list(outlines)
        if not self._fitted and scene.points.shape[0]:
            self.camera.fit(scene.bounds(), self._aspect())
            self._fitted = True
        self._cache = None
        self.update()

    def _aspect(self) -> float:
        return self.width() / max(self.height(), 1)

    def reset_view(self) -> None:
        self.camera.fit(self.scene.bounds(), self._aspect())
        self._fitted = self.scene.points.shape[0] > 0
        self._changed()

    def set_point_size(self, size: int) -> None:
        self.point_size = max(1, min(int(size), 4))
        self._changed()

    def set_hidden(self, hidden: frozenset[int]) -> None:
        self.hidden = frozenset(hidden)
        self._changed()

    def _changed(self) -> None:
        self._cache = None
        self.update()
        self.viewChanged.emit()

    # -- rendering ------------------------------------------------------------------------------------
    def render_image(self) -> ImageBuffer:
        """The cloud rendered at the widget's size; cached until the scene, view or size changes."""
        c = self.camera
        key = (id(self.scene), self.width(), self.height(), tuple(c.target), c.distance, c.yaw, c.pitch,
               self.point_size, self.hidden)
        if self._cache is None or self._cache[0] != key:
            rgb = render(self.scene, c, self.width(), self.height(), point_size=self.point_size, hidden=self.hidden)
            self._cache = (key, rgb_qimage(rgb))
        return self._cache[1]

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.camera.project(points, self.width(), self.height())

    def paintEvent(self, event: QPaintEvent) -> None:  # noqa: N802 - Qt override
        painter = QPainter(self)
        painter.drawImage(0, 0, self.render_image().qimage)
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        for number, outline in enumerate(self.outlines, 1):
            if outline is not None and outline.box is not None:
                self._draw_box(painter, outline, number)
        self._draw_legend(painter)
        painter.end()

    def _line(self, painter: QPainter, a: np.ndarray, b: np.ndarray, da: float, db: float) -> None:
        if da > NEAR and db > NEAR:
            painter.drawLine(QPointF(*a), QPointF(*b))

    def _draw_box(self, painter: QPainter, outline: Outline, number: int) -> None:
        geometry = box_frame(outline.box)
        if geometry is None:
            return
        centre, axes, sides = geometry
        uv, depth = self.project(np.asarray(outline.box, dtype=np.float64))
        painter.setPen(QPen(BOX_COLOUR, 2))
        for i, j in BOX_EDGES:
            self._line(painter, uv[i], uv[j], depth[i], depth[j])
        # A small coordinate frame at the centre: the box's local x (red), y (green), z (blue).
        length = float(np.clip(0.6 * sides.max() / 2.0, 0.01, 0.25))
        ends = centre + axes * length
        uv_axes, depth_axes = self.project(np.vstack([centre[None, :], ends]))
        for axis in range(3):
            painter.setPen(QPen(AXIS_COLOURS[axis], 2))
            self._line(painter, uv_axes[0], uv_axes[axis + 1], depth_axes[0], depth_axes[axis + 1])
        if depth_axes[0] > NEAR:
            painter.setPen(QPen(BOX_COLOUR))
            painter.setFont(QFont(painter.font().family(), 9))
            top = uv[np.argmin(uv[:, 1])] if np.all(depth > NEAR) else uv_axes[0]
            painter.drawText(QPointF(top[0] + 4, top[1] - 4), f"{number}: {outline.label}")

    def _draw_legend(self, painter: QPainter) -> None:
        painter.setFont(QFont(painter.font().family(), 9))
        y = 8.0
        for index, name in enumerate(self.scene.names):
            colour = QColor(*layer_colour(index))
            if index in self.hidden:
                colour.setAlpha(70)
            painter.fillRect(QRectF(8, y, 12, 12), colour)
            painter.setPen(QPen(QColor(230, 230, 230) if index not in self.hidden else QColor(120, 120, 120)))
            count = self.scene.counts[index] if index < len(self.scene.counts) else 0
            painter.drawText(QPointF(26, y + 11), f"{name}  ({count:,} points)")
            y += 17
        if self.outlines:
            painter.fillRect(QRectF(8, y, 12, 12), BOX_COLOUR)
            painter.setPen(QPen(QColor(230, 230, 230)))
            painter.drawText(QPointF(26, y + 11), f"{len(self.outlines)} detected")

    # -- interaction ------------------------------------------------------------------------------------
    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        self._drag = (event.position(), event.button(), event.modifiers())

    def mouseMoveEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        if self._drag is None:
            return
        start, button, modifiers = self._drag
        delta = event.position() - start
        pan = button in (Qt.MouseButton.RightButton, Qt.MouseButton.MiddleButton) or bool(
            modifiers & Qt.KeyboardModifier.ShiftModifier
        )
        if pan:
            self.camera.pan(delta.x(), delta.y(), self.height())
        else:
            self.camera.rotate(delta.x() * ROTATE_SPEED, -delta.y() * ROTATE_SPEED)
        self._drag = (event.position(), button, modifiers)
        self._changed()

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        self._drag = None

    def mouseDoubleClickEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        self.reset_view()

    def wheelEvent(self, event: QWheelEvent) -> None:  # noqa: N802 - Qt override
        steps = event.angleDelta().y() / 120.0
        self.camera.zoom(0.85**steps)
        self._changed()

    def keyPressEvent(self, event: QKeyEvent) -> None:  # noqa: N802 - Qt override
        key = event.key()
        if key == Qt.Key.Key_R:
            self.reset_view()
        elif key in (Qt.Key.Key_Plus, Qt.Key.Key_Equal):
            self.camera.zoom(0.85)
            self._changed()
        elif key == Qt.Key.Key_Minus:
            self.camera.zoom(1 / 0.85)
            self._changed()
        else:
            super().keyPressEvent(event)
