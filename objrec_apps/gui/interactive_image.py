"""InteractiveImage: a picture scaled to the widget, with mouse events and area selection in image pixels
(widget pixels would shift as soon as the window was resized)."""

from __future__ import annotations

from typing import Any

import numpy as np
from PySide6.QtCore import QPointF, QRectF, QSize, Qt, Signal
from PySide6.QtGui import QColor, QMouseEvent, QPainter, QPaintEvent, QPen
from PySide6.QtWidgets import QSizePolicy, QWidget

from objrec_core import Rect

from .images import ImageBuffer, bgrx_qimage, displayable

#: A drag smaller than this (in image pixels, either side) is a click, not a selection.
MIN_SELECTION = 3


class InteractiveImage(QWidget):
    """Shows an image scaled with its aspect ratio kept and reports the mouse in image coordinates.

    While the user drags, a rubber band is drawn and the displayed image is held still, so the selection
    refers to the picture the user is looking at; images that arrive meanwhile are shown on release.
    ``areaSelected`` carries an ``objrec_core.Rect`` clipped to the image; ``tag`` is whatever the caller
    attached to the displayed image (the GUI attaches the frame's results).
    """

    mousePressed = Signal(QPointF)  # noqa: N815 - Qt's signal naming
    mouseMoved = Signal(QPointF)  # noqa: N815 - Qt's signal naming
    mouseReleased = Signal(QPointF)  # noqa: N815 - Qt's signal naming
    mouseLeft = Signal()  # noqa: N815 - Qt's signal naming
    areaSelected = Signal(object)  # noqa: N815 - Qt's signal naming

    def __init__(self, parent: QWidget | None = None, *, selectable: bool = True) -> None:
        super().__init__(parent)
        self.selectable = selectable
        self._array: np.ndarray | None = None  # what is shown, at its own size: coordinates and pixels
        self._buffer: ImageBuffer | None = None  # its QImage, made when first needed
        self._display: ImageBuffer | None = None  # a copy already scaled to this widget (see set_image)
        self._tag: Any = None
        self._pending: tuple[np.ndarray | None, Any, np.ndarray | None] | None = None
        self._drag_start: QPointF | None = None
        self._drag_end: QPointF | None = None
        #: The tag of the image last painted and how many paints so far (the benchmark counts these).
        self.painted_tag: Any = None
        self.paint_count = 0
        #: The keyboard modifiers held when the last selection was released (Shift: the HSV eyedropper).
        self.selection_modifiers = Qt.KeyboardModifier.NoModifier
        #: A tool that takes the mouse instead of the area selection and paints over the image (the label
        #: mode, label_tool.py): ``mouse(view, what, point, event) -> bool`` (True: handled) and
        #: ``paint(painter, view)``; None for the usual selection.
        self.tool: Any = None
        self.setMouseTracking(True)
        self.setMinimumSize(160, 120)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setAttribute(Qt.WidgetAttribute.WA_OpaquePaintEvent)

    # -- the image ------------------------------------------------------------------------------------
    def set_image(self, image: np.ndarray | None, tag: Any = None, display: np.ndarray | None = None) -> None:
        """Show ``image`` (BGR, grey or any array ``displayable`` accepts); held back while dragging.

        ``display`` is the same picture already scaled to fit this widget as a ``display_buffer`` (made off
        the GUI thread); it is painted without scaling while the widget keeps that size.
        """
        if self._drag_start is not None:
            self._pending = (image, tag, display)
            return
        self._array = None if image is None else displayable(image)
        self._buffer = None
        self._display = None if display is None or image is None else bgrx_qimage(display)
        self._tag = tag
        self.update()

    def image(self) -> np.ndarray | None:
        """The array being displayed (8-bit grey or BGR)."""
        return self._array

    def _qimage(self) -> ImageBuffer:
        assert self._array is not None
        if self._buffer is None:
            self._buffer = ImageBuffer.from_array(self._array)
        return self._buffer

    @property
    def tag(self) -> Any:
        return self._tag

    def image_size(self) -> tuple[int, int]:
        """Width and height of the image, or (0, 0)."""
        return (0, 0) if self._array is None else (int(self._array.shape[1]), int(self._array.shape[0]))

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt override
        if self._array is None:
            return QSize(320, 240)
        width, height = self.image_size()
        return QSize(min(width, 640), min(height, 480))

    # -- coordinates ----------------------------------------------------------------------------------
    def image_rect(self) -> QRectF:
        """Where the image is drawn in the widget: scaled to fit, aspect kept, centred."""
        if self._array is None:
            return QRectF()
        image_width, image_height = self.image_size()
        scale = min(self.width() / image_width, self.height() / image_height)
        width, height = image_width * scale, image_height * scale
        return QRectF((self.width() - width) / 2, (self.height() - height) / 2, width, height)

    def to_image(self, pos: QPointF) -> QPointF:
        """Widget position to image coordinates (pixel i spans i..i+1)."""
        area = self.image_rect()
        if area.isEmpty():
            return QPointF(-1, -1)
        scale = area.width() / self.image_size()[0]
        return QPointF((pos.x() - area.left()) / scale, (pos.y() - area.top()) / scale)

    def to_widget(self, point: QPointF) -> QPointF:
        area = self.image_rect()
        if area.isEmpty():
            return QPointF()
        scale = area.width() / self.image_size()[0]
        return QPointF(area.left() + point.x() * scale, area.top() + point.y() * scale)

    def contains(self, point: QPointF) -> bool:
        """True when an image coordinate lies on the image."""
        width, height = self.image_size()
        return 0 <= point.x() < width and 0 <= point.y() < height

    def _clamped(self, point: QPointF) -> QPointF:
        width, height = self.image_size()
        return QPointF(min(max(point.x(), 0.0), width), min(max(point.y(), 0.0), height))

    def selection(self) -> Rect | None:
        """The rectangle being dragged, clipped to the image, or None."""
        if self._drag_start is None or self._drag_end is None:
            return None
        a, b = self._drag_start, self._drag_end
        # Corners snap to the nearest pixel boundary, as Rect.from_corners does for any drag direction.
        if abs(round(a.x()) - round(b.x())) < MIN_SELECTION or abs(round(a.y()) - round(b.y())) < MIN_SELECTION:
            return None
        return Rect.from_corners(a.x(), a.y(), b.x(), b.y())

    # -- mouse ------------------------------------------------------------------------------------------
    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        point = self.to_image(event.position())
        self.mousePressed.emit(point)
        if self.tool is not None and self.tool.mouse(self, "press", point, event):
            return
        if self.selectable and event.button() == Qt.MouseButton.LeftButton and self.contains(point):
            self._drag_start = self._drag_end = point
            self.update()

    def mouseMoveEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        point = self.to_image(event.position())
        self.mouseMoved.emit(point)
        if self.tool is not None and self.tool.mouse(self, "move", point, event):
            return
        if self._drag_start is not None:
            self._drag_end = self._clamped(point)
            self.update()

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        point = self.to_image(event.position())
        self.mouseReleased.emit(point)
        if self.tool is not None and self.tool.mouse(self, "release", point, event):
            return
        if self._drag_start is None or event.button() != Qt.MouseButton.LeftButton:
            return
        self._drag_end = self._clamped(point)
        rect = self.selection()
        if rect is not None:
            self.selection_modifiers = event.modifiers()
            self.areaSelected.emit(rect)  # the held image and its tag are still current here
        self._drag_start = self._drag_end = None
        pending, self._pending = self._pending, None
        if pending is not None:
            self.set_image(*pending)
        self.update()

    def mouseDoubleClickEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        if self.tool is not None and self.tool.mouse(self, "double", self.to_image(event.position()), event):
            return
        super().mouseDoubleClickEvent(event)

    def leaveEvent(self, event: Any) -> None:  # noqa: N802 - Qt override
        self.mouseLeft.emit()
        super().leaveEvent(event)

    # -- painting -----------------------------------------------------------------------------------------
    def paintEvent(self, event: QPaintEvent) -> None:  # noqa: N802 - Qt override
        painter = QPainter(self)
        painter.fillRect(self.rect(), QColor(40, 40, 40))
        if self._array is not None:
            area = self.image_rect()
            display = self._display
            fits = display is not None and abs(display.width - area.width()) <= 1 and abs(
                display.height - area.height()) <= 1
            if display is not None and fits:
                painter.drawImage(round(area.left()), round(area.top()), display.qimage)  # a plain copy
            else:  # resized since the display copy was made: scale here until the next frame
                if area.width() < self.image_size()[0]:  # shrinking: smooth, or thin mask lines vanish
                    painter.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform)
                painter.drawImage(area, self._qimage().qimage)
            self.painted_tag = self._tag
            self.paint_count += 1
        if self._drag_start is not None and self._drag_end is not None:
            a, b = self.to_widget(self._drag_start), self.to_widget(self._drag_end)
            band = QRectF(a, b).normalized()
            painter.setPen(QPen(QColor(255, 255, 255), 1, Qt.PenStyle.DashLine))
            painter.fillRect(band, QColor(80, 160, 255, 60))
            painter.drawRect(band)
        if self.tool is not None and self._array is not None:
            self.tool.paint(painter, self)
        painter.end()
