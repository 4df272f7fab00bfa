"""Every stage of a pipeline on screen, not only the last: the original with the detections, each filter's
output and each detector's debug view, as tabs or as a grid (the user's choice).

The pictures come from the pipeline's data kind (``kind.annotate``, ``kind.preview``), so a kind with
neither images nor clouds shows its stages all the same; kinds whose views show points use the 3D page.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from PySide6.QtCore import QPointF, Qt, Signal
from PySide6.QtWidgets import QFrame, QGridLayout, QLabel, QStackedLayout, QTabWidget, QVBoxLayout, QWidget

from objrec_core import Frame, Kind, StageResults

from .images import FAST_DISPLAY, describe_pixel, display_buffer, display_keeping_drawing, fit_size
from .interactive_image import InteractiveImage

log = logging.getLogger(__name__)

MODES = ("tabs", "grid")
NO_FRAME = "No frame yet: choose a source above."

#: Stages whose picture failed, each reported once (a view refreshes at camera rate).
_reported: set[tuple[str, str]] = set()


@dataclass
class StageImage:
    """One picture to show: a key that stays the same from frame to frame, a title and the image."""

    key: str
    title: str
    image: np.ndarray
    display: np.ndarray | None = None  # the image scaled for its view, where the view's size was known
    base: np.ndarray | None = None  # the picture ``image`` was drawn on (detections), kept visible when scaled


def _is_image(value: Any) -> bool:
    """A detector's debug view is a picture (H x W or H x W x 3/4 array) whatever the data kind."""
    return isinstance(value, np.ndarray) and value.ndim in (2, 3) and value.size > 0


def _raw(data: Any, shown: np.ndarray) -> np.ndarray | None:
    """``data`` when it is itself a picture the size of ``shown`` (its pixels can be read out), else None."""
    return data if _is_image(data) and data.shape[:2] == shown.shape[:2] else None


def _picture(key: str, draw: Callable[[], Any]) -> np.ndarray | None:
    """``draw()``, or None (reported once per stage and error) when the kind cannot picture the data."""
    try:
        picture = draw()
    except Exception as exc:  # a filter whose output its kind cannot show must not blank the other stages
        if (key, type(exc).__name__) not in _reported:
            _reported.add((key, type(exc).__name__))
            log.warning("stage %s cannot be shown: %s: %s", key, type(exc).__name__, exc)
        return None
    return picture if _is_image(picture) else None


def stage_images(
    results: StageResults, kind: Kind, sizes: Mapping[str, tuple[int, int]] | None = None
) -> list[StageImage]:
    """The pictures for one frame, in pipeline order, drawn by the data kind; each scaled for display where
    ``sizes`` (view key -> widget width and height) gives its view's size."""
    images = []
    for stage in results.stages:
        label = stage.id if stage.id == stage.type_name else f"{stage.id} ({stage.type_name})"
        if stage.role == "input":
            picture = _picture("input", lambda: kind.annotate(results.frame, results.objects))
            if picture is not None:
                base = results.frame.data if _is_image(results.frame.data) else None
                images.append(StageImage("input", "original + detections", picture, base=base))
        elif stage.role == "filter":
            picture = _picture(stage.id, lambda output=stage.output: kind.preview(output))
            if picture is not None:
                images.append(StageImage(stage.id, label, picture))
        else:
            debug = stage.debug
            views = debug if isinstance(debug, dict) else {"debug": debug} if debug is not None else {}
            shown = False
            for name, view in views.items():
                if _is_image(view):
                    images.append(StageImage(f"{stage.id}:{name}", f"{label} {name}", view))
                    shown = True
            if not shown:
                found = type(results.objects)(header=results.objects.header, objects=list(stage.objects))
                picture = _picture(stage.id, lambda s=stage, a=found: kind.annotate(Frame(s.output), a))
                if picture is not None:
                    base = stage.output if _is_image(stage.output) else None
                    images.append(StageImage(stage.id, f"{label}: its input + detections", picture, base=base))
    for item in images:
        size = sizes.get(item.key) if sizes else None
        if size is not None:
            height, width = item.image.shape[:2]
            fitted = fit_size(width, height, *size)
            item.display = display_buffer(item.image, fitted) if item.base is None else \
                display_keeping_drawing(item.image, item.base, fitted)
    return images


class _Cell(QFrame):
    def __init__(self, title: str, view: InteractiveImage) -> None:
        super().__init__()
        self.title = QLabel(title)
        self.title.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.view = view
        self.aspect = 4 / 3  # of the image it shows: the grid is laid out to give images the most room
        layout = QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.setSpacing(2)
        layout.addWidget(self.title)
        layout.addWidget(view, 1)


class StageViews(QWidget):
    """The stage pictures. ``areaSelected(rect, results)`` comes from any view showing a picture the size of
    the original's; ``hovered(text)`` describes the pixel under the mouse (coordinates, BGR and HSV)."""

    areaSelected = Signal(object, object)  # noqa: N815 - Qt's signal naming
    hovered = Signal(str)
    modeChanged = Signal(str)  # noqa: N815 - Qt's signal naming

    def __init__(self, mode: str = "tabs", parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._mode = mode if mode in MODES else "tabs"
        self._columns = 0
        self._cells: dict[str, _Cell] = {}
        self._results: StageResults | None = None
        #: The keyboard modifiers of the last selection (read by the window while it hands the selection on).
        self.selection_modifiers: Any = None
        #: Sizes of the views on screen, read by the processing thread to scale the next frame for them.
        self.display_sizes: dict[str, tuple[int, int]] = {}
        self.tabs = QTabWidget()
        self.tabs.setDocumentMode(True)
        self.grid_page = QWidget()
        self.grid = QGridLayout(self.grid_page)
        self.grid.setContentsMargins(0, 0, 0, 0)
        self.grid.setSpacing(4)
        self.stack = QStackedLayout(self)
        self.stack.addWidget(self.tabs)
        self.stack.addWidget(self.grid_page)
        self.placeholder = QLabel(NO_FRAME)
        self.placeholder.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.placeholder.setWordWrap(True)
        self.stack.addWidget(self.placeholder)
        self.stack.setCurrentWidget(self.placeholder)

    # -- content --------------------------------------------------------------------------------------
    @property
    def mode(self) -> str:
        return self._mode

    @property
    def views(self) -> dict[str, InteractiveImage]:
        return {key: cell.view for key, cell in self._cells.items()}

    def view(self, key: str) -> InteractiveImage:
        return self._cells[key].view

    @property
    def results(self) -> StageResults | None:
        return self._results

    def show_results(self, results: StageResults, kind: Kind, images: list[StageImage] | None = None) -> None:
        """Show a frame's stages; ``images`` when already drawn (by the worker thread)."""
        if images is None:
            images = stage_images(results, kind)
        keys = [i.key for i in images]
        if keys != list(self._cells):
            self._rebuild(images)
        # Selections are in the original's pixels: views of another size (a side-by-side debug view) take none.
        frame_shape = next((i.image.shape[:2] for i in images if i.key == "input"), None)
        retitled = False
        aspects = [item.image.shape[1] / max(item.image.shape[0], 1) for item in images]
        if [cell.aspect for cell in self._cells.values()] != aspects:
            for cell, aspect in zip(self._cells.values(), aspects, strict=True):
                cell.aspect = aspect
            if self._mode == "grid":
                self._place()
        for item in images:
            cell = self._cells[item.key]
            if cell.title.text() != item.title:
                cell.title.setText(item.title)
                retitled = True
            cell.view.selectable = item.image.shape[:2] == frame_shape
            cell.view.set_image(item.image, results, item.display)
        if retitled:
            self._sync_tab_titles()
        self._results = results
        if FAST_DISPLAY:
            self.display_sizes = {key: (cell.view.width(), cell.view.height())
                                  for key, cell in self._cells.items() if cell.view.isVisible()}

    def clear(self) -> None:
        self._rebuild([])
        self._results = None
        self.placeholder.setText(NO_FRAME)

    def set_placeholder(self, text: str) -> None:
        """What the page says while it has no frame (why none comes, what to do)."""
        self.placeholder.setText(text)

    def _rebuild(self, images: list[StageImage]) -> None:
        current = self.tabs.tabText(self.tabs.currentIndex()) if self.tabs.count() else ""
        old = self._cells
        self._cells = {}
        for item in images:
            cell = old.pop(item.key, None)
            if cell is None:
                view = InteractiveImage()
                view.areaSelected.connect(lambda rect, v=view: self._selected(rect, v))
                view.mouseMoved.connect(lambda point, k=item.key: self._hover(k, point))
                view.mouseLeft.connect(lambda: self.hovered.emit(""))
                cell = _Cell(item.title, view)
            self._cells[item.key] = cell
        for cell in old.values():
            cell.hide()
            cell.deleteLater()
        self._place()
        if current:
            for index in range(self.tabs.count()):
                if self.tabs.tabText(index) == current:
                    self.tabs.setCurrentIndex(index)

    def _selected(self, rect: Any, view: InteractiveImage) -> None:
        self.selection_modifiers = view.selection_modifiers
        try:
            self.areaSelected.emit(rect, view.tag)
        finally:
            self.selection_modifiers = None

    # -- layout ---------------------------------------------------------------------------------------
    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"view mode must be one of {', '.join(MODES)}, not {mode!r}")
        if mode != self._mode:
            self._mode = mode
            self._place()
            self.modeChanged.emit(mode)

    def _place(self) -> None:
        while self.tabs.count():
            self.tabs.removeTab(0)
        while self.grid.count():
            self.grid.takeAt(0)
        cells = list(self._cells.values())
        if not cells:
            self.stack.setCurrentWidget(self.placeholder)
            return
        if self._mode == "tabs":
            for cell in cells:
                cell.title.hide()
                self.tabs.addTab(cell, cell.title.text())
            self.stack.setCurrentWidget(self.tabs)
        else:
            columns = self.best_columns()
            self._columns = columns
            for index, cell in enumerate(cells):
                cell.setParent(self.grid_page)
                cell.title.show()
                self.grid.addWidget(cell, index // columns, index % columns)
                cell.show()
            self.stack.setCurrentWidget(self.grid_page)
        self._sync_tab_titles()

    def best_columns(self) -> int:
        """The number of grid columns that shows the images largest in this widget's shape."""
        aspects = [cell.aspect for cell in self._cells.values()]
        width, height = max(self.width(), 1), max(self.height(), 1)
        title = 24  # a cell's caption
        best, best_area = 1, -1.0
        for columns in range(1, len(aspects) + 1):
            rows = math.ceil(len(aspects) / columns)
            cell_w, cell_h = width / columns, max(height / rows - title, 1.0)
            area = sum(min(cell_w, cell_h * a) * min(cell_h, cell_w / a) for a in aspects)
            if area > best_area * 1.02:  # prefer fewer columns unless more are clearly better
                best, best_area = columns, area
        return best

    def resizeEvent(self, event: Any) -> None:  # noqa: N802 - Qt override
        super().resizeEvent(event)
        if self._mode == "grid" and self._cells and self.best_columns() != self._columns:
            self._place()

    def _sync_tab_titles(self) -> None:
        for index in range(self.tabs.count()):
            cell = self.tabs.widget(index)
            if isinstance(cell, _Cell):
                self.tabs.setTabText(index, cell.title.text())

    # -- hover ----------------------------------------------------------------------------------------------
    def _hover(self, key: str, point: QPointF) -> None:
        cell = self._cells.get(key)
        results = self._results
        if cell is None or results is None or not cell.view.contains(point):
            self.hovered.emit("")
            return
        x, y = int(point.x()), int(point.y())
        shown = cell.view.image()
        text = f"x {x}, y {y}"
        if shown is None:
            self.hovered.emit(text)
            return
        # The data's own values where the frame, or the stage's output, is a picture the view's size (a mask
        # reads "value 255", not its preview's BGR); else the picture's.
        original = _raw(results.frame.data, shown)
        output = _raw(next((s.output for s in results.stages if s.id == key and s.role == "filter"), None), shown)
        if original is not None:
            text += f"   {describe_pixel(original, x, y)}"
            if key != "input":
                text += f"   {key}: {describe_pixel(output if output is not None else shown, x, y)}"
        else:
            text += f"   {describe_pixel(output if output is not None else shown, x, y)}"
        self.hovered.emit(text)
