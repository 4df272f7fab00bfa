"""Drawing labels on the frame on screen: the mouse tool the label mode gives the input view.

Box shape: drag a box. Polygon shape: click each corner, double-click to close (three corners at least);
Escape drops the polygon under way. A click that does not draw (a box drag shorter than a few pixels, or any
click with Ctrl held) selects the label under it, or none. Everything is in image pixels, so a label stays
on its object when the window is resized.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QFont, QMouseEvent, QPainter, QPen, QPolygonF

from .interactive_image import MIN_SELECTION, InteractiveImage
from .label_model import Label

SHAPES = ("box", "polygon")
#: Labels in magenta (the detections are drawn in yellow and green): truth and results never look alike.
COLOUR = QColor(255, 0, 220)
SELECTED = QColor(0, 230, 255)
DRAWING = QColor(255, 255, 255)
FILL_ALPHA = 50


class LabelTool:
    """The mouse tool of the label mode (set as ``InteractiveImage.tool``).

    ``labels()`` gives the labels of the frame on screen; ``finished(points, is_box)`` is called with a box's
    two corners or a polygon's corners; ``select(index | None)`` with the label clicked.
    """

    def __init__(self, labels: Callable[[], tuple[Label, ...]], finished: Callable[[list[QPointF], bool], None],
                 select: Callable[[int | None], None]) -> None:
        self.labels = labels
        self.finished = finished
        self.select = select
        self.shape = "box"
        self.selected: int | None = None
        self._drag: tuple[QPointF, QPointF] | None = None
        self._polygon: list[QPointF] = []
        self._hover: QPointF | None = None

    @property
    def drawing(self) -> bool:
        return self._drag is not None or bool(self._polygon)

    def cancel(self) -> None:
        """Drop the shape under way."""
        self._drag, self._polygon = None, []

    def _pick(self, point: QPointF) -> None:
        hits = [i for i, label in enumerate(self.labels()) if label.contains(point.x(), point.y())]
        self.select(hits[-1] if hits else None)  # the last drawn is on top

    def mouse(self, view: InteractiveImage, what: str, point: QPointF, event: QMouseEvent) -> bool:
        left = event.button() == Qt.MouseButton.LeftButton
        if what == "move":
            if self._drag is not None:
                self._drag = (self._drag[0], _clamped(view, point))
            self._hover = point
            view.update()
            return True
        if what == "press" and left:
            if event.modifiers() & Qt.KeyboardModifier.ControlModifier and not self._polygon:
                self._pick(point)
            elif not view.contains(point):
                return True
            elif self.shape == "box":
                self._drag = (point, point)
            else:
                self._polygon.append(point)
            view.update()
            return True
        if what == "release" and left and self._drag is not None:
            start, end = self._drag[0], _clamped(view, point)
            self._drag = None
            if abs(end.x() - start.x()) < MIN_SELECTION or abs(end.y() - start.y()) < MIN_SELECTION:
                self._pick(start)
            else:
                self.finished([start, end], True)
            view.update()
            return True
        if what == "double" and left and self.shape == "polygon":
            corners = _distinct(self._polygon)
            self._polygon = []
            if len(corners) >= 3:
                self.finished(corners, False)
            view.update()
            return True
        return what != "double"

    def paint(self, painter: QPainter, view: InteractiveImage) -> None:
        painter.save()
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        font = QFont(painter.font())
        font.setBold(True)
        painter.setFont(font)
        metrics = painter.fontMetrics()
        for index, label in enumerate(self.labels()):
            colour = SELECTED if index == self.selected else COLOUR
            fill = QColor(colour)
            fill.setAlpha(FILL_ALPHA)
            painter.setPen(QPen(colour, 3 if index == self.selected else 2, Qt.PenStyle.DashLine))
            painter.setBrush(fill)
            left, top, width, height = label.bounds
            corner = view.to_widget(QPointF(left, top))
            if label.polygon:
                painter.drawPolygon(QPolygonF([view.to_widget(QPointF(x, y)) for x, y in label.polygon]))
            else:
                painter.drawRect(QRectF(corner, view.to_widget(QPointF(left + width, top + height))))
            tag = QRectF(corner.x(), corner.y() - metrics.height() - 2, metrics.horizontalAdvance(label.name) + 8,
                         metrics.height() + 2)
            painter.fillRect(tag, colour)
            painter.setPen(QColor(0, 0, 0))
            painter.drawText(tag, Qt.AlignmentFlag.AlignCenter, label.name)
        painter.setBrush(Qt.BrushStyle.NoBrush)
        painter.setPen(QPen(DRAWING, 2, Qt.PenStyle.DashLine))
        if self._drag is not None:
            painter.drawRect(QRectF(view.to_widget(self._drag[0]), view.to_widget(self._drag[1])).normalized())
        if self._polygon:
            points = [view.to_widget(p) for p in self._polygon]
            if self._hover is not None:
                points.append(view.to_widget(self._hover))
            painter.drawPolyline(QPolygonF(points))
            painter.setBrush(DRAWING)
            for point in points[:len(self._polygon)]:
                painter.drawEllipse(point, 3.5, 3.5)
        painter.restore()


def _clamped(view: InteractiveImage, point: QPointF) -> QPointF:
    width, height = view.image_size()
    return QPointF(min(max(point.x(), 0.0), width), min(max(point.y(), 0.0), height))


def _distinct(points: list[QPointF]) -> list[QPointF]:
    """The corners without repeats (a double-click's press lands on the last corner again)."""
    kept: list[QPointF] = []
    for point in points:
        if not kept or abs(point.x() - kept[-1].x()) > 0.5 or abs(point.y() - kept[-1].y()) > 0.5:
            kept.append(point)
    return kept


def label_from(points: list[QPointF], is_box: bool, name: str) -> Label:
    """The label a finished drawing makes, its coordinates rounded to a tenth of a pixel."""
    if is_box:
        a, b = points
        left, top = min(a.x(), b.x()), min(a.y(), b.y())
        return Label(name, (round(left, 1), round(top, 1), round(abs(b.x() - a.x()), 1), round(abs(b.y() - a.y()), 1)))
    return Label(name, None, tuple((round(p.x(), 1), round(p.y(), 1)) for p in points))

