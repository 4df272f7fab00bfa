"""Keeping the definition window within a laptop's screen (1280x800 and up).

Two things made the window outgrow the screen and stay so: a QStackedWidget asks for the minimum size of
its widest page, shown or not (the 3D page kept a 2D pipeline's window at 1374 px after a 3D one), and a
window restored or grown on a larger screen kept its size. ``PageStack`` sizes to the page on screen;
``fit_to_screen`` brings a window back inside the screen's free area.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import QRect, QSize
from PySide6.QtWidgets import QSizePolicy, QStackedWidget, QWidget

log = logging.getLogger(__name__)


class PageStack(QStackedWidget):
    """A stack of pages whose size hints are those of the page on screen: a hidden page's controls never
    widen the window."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._policies: dict[int, QSizePolicy] = {}  # each page's own size policy, by id
        self.currentChanged.connect(self._page_changed)

    def _page_changed(self, _index: int) -> None:
        current = self.currentWidget()
        for index in range(self.count()):
            page = self.widget(index)
            if page is current:
                page.setSizePolicy(self._policies.get(id(page), page.sizePolicy()))
            else:  # the stacked layout leaves out an Ignored page's minimum size
                page.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
        self.updateGeometry()

    def addWidget(self, page: QWidget) -> int:  # noqa: N802 - Qt override
        self._policies[id(page)] = QSizePolicy(page.sizePolicy())
        index = super().addWidget(page)
        self._page_changed(self.currentIndex())
        return index

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt override
        current = self.currentWidget()
        return current.sizeHint() if current is not None else super().sizeHint()

    def minimumSizeHint(self) -> QSize:  # noqa: N802 - Qt override
        current = self.currentWidget()
        return current.minimumSizeHint() if current is not None else super().minimumSizeHint()


def screen_area(widget: QWidget) -> QRect | None:
    """The free area (without task bars) of the screen the widget is on, or of the primary screen."""
    screen = widget.screen()
    return screen.availableGeometry() if screen is not None else None


def fit_to_screen(window: QWidget, area: QRect | None = None) -> bool:
    """Shrink and move ``window`` so its frame lies within ``area`` (default: its screen's free area), never
    below its minimum size; True when it had to. A window already inside is left alone."""
    area = area if area is not None else screen_area(window)
    if area is None or area.isEmpty():
        return False
    frame, inner = window.frameGeometry(), window.geometry()
    extra_w, extra_h = frame.width() - inner.width(), frame.height() - inner.height()
    if area.contains(frame):
        return False
    minimum = window.minimumSize().expandedTo(window.minimumSizeHint())
    width = max(min(inner.width(), area.width() - extra_w), minimum.width())
    height = max(min(inner.height(), area.height() - extra_h), minimum.height())
    if (width, height) != (inner.width(), inner.height()):
        window.resize(width, height)
    x = min(max(frame.x(), area.x()), area.x() + max(area.width() - width - extra_w, 0))
    y = min(max(frame.y(), area.y()), area.y() + max(area.height() - height - extra_h, 0))
    window.move(x, y)
    log.debug("window fitted to the screen: %dx%d at (%d, %d)", width, height, x, y)
    return True
