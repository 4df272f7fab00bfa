"""The status bar's message, cut at a word and never under the pixel read-out.

QStatusBar draws a temporary message clipped at the edge of its room, so a long one ends mid-word ("the
pipeline has no HSV fil"). This bar draws the same message shortened at a space, with an ellipsis, inside the
room left of its permanent widgets (the pixel read-out, the file path); the whole text stays in
``currentMessage()``, in the tooltip and in the message area.
"""

from __future__ import annotations

from PySide6.QtCore import QRect, Qt
from PySide6.QtGui import QFontMetrics, QPainter, QPaintEvent
from PySide6.QtWidgets import QStatusBar, QStyle, QStyleOption, QWidget

ELLIPSIS = " …"


def fit_at_word(text: str, metrics: QFontMetrics, width: int) -> str:
    """``text`` whole when it fits in ``width`` pixels, else its longest start ending at a word that fits
    with an ellipsis after it; a first word too long on its own is cut with Qt's elision."""
    text = " ".join(text.split())  # one line
    if metrics.horizontalAdvance(text) <= width:
        return text
    words = text.split(" ")
    low, high = 0, len(words)  # the most words whose start plus the ellipsis fits
    while low < high:
        middle = (low + high + 1) // 2
        if metrics.horizontalAdvance(" ".join(words[:middle]).rstrip(",;:") + ELLIPSIS) <= width:
            low = middle
        else:
            high = middle - 1
    if low == 0:
        return metrics.elidedText(text, Qt.TextElideMode.ElideRight, width)
    return " ".join(words[:low]).rstrip(",;:") + ELLIPSIS


class MessageBar(QStatusBar):
    """A QStatusBar whose temporary message is shortened at a word to the room left of the permanent
    widgets."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.messageChanged.connect(self.setToolTip)

    def message_room(self) -> QRect:
        """Where the message may be drawn: from the left edge to the first permanent widget shown."""
        left, right = 6, self.width() - 12
        for widget in self.findChildren(QWidget, options=Qt.FindChildOption.FindDirectChildrenOnly):
            if widget.isVisible() and self._is_permanent(widget):
                right = min(right, widget.x() - 4)
        return QRect(left, 0, max(0, right - left), self.height())

    def _is_permanent(self, widget: QWidget) -> bool:
        return bool(widget.property("objrec_permanent"))

    def addPermanentWidget(self, widget: QWidget, stretch: int = 0) -> None:  # noqa: N802 - Qt override
        widget.setProperty("objrec_permanent", True)
        super().addPermanentWidget(widget, stretch)

    def shown_text(self) -> str:
        """The message as drawn (shortened at a word when it does not fit)."""
        return fit_at_word(self.currentMessage(), self.fontMetrics(), self.message_room().width())

    def paintEvent(self, event: QPaintEvent) -> None:  # noqa: N802 - Qt override
        message = self.currentMessage()
        if not message:
            super().paintEvent(event)
            return
        painter = QPainter(self)
        option = QStyleOption()
        option.initFrom(self)
        self.style().drawPrimitive(QStyle.PrimitiveElement.PE_PanelStatusBar, option, painter, self)
        room = self.message_room()
        painter.setPen(self.palette().windowText().color())
        painter.drawText(room, int(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter),
                         fit_at_word(message, self.fontMetrics(), room.width()))
        painter.end()
