"""The label mode of objrec-define: mark the objects of the frames of a source, save them as ground truth.

Tools > Label frames turns it on: the source pauses (step through it with the seek bar or Step), the input
view takes the mouse (label_tool.py: drag boxes, click polygons) and a toolbar gives the shape, the name (the
names used so far; the system's object name first) and Delete. Every edit is an undo step on the window's
stack. File > Open labels / Save labels read and write the kind's label file (2D: COCO JSON) through
``Kind.read_truth`` / ``Kind.write_truth`` (the save is atomic); labels not saved are asked about before
quitting, as unsaved parameters are.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from PySide6.QtCore import QObject, QPointF, Signal
from PySide6.QtGui import QAction, QActionGroup, QKeySequence
from PySide6.QtWidgets import QComboBox, QFileDialog, QLabel, QToolBar

from objrec_core import Frame, Kind, get_kind
from objrec_core.kinds import NoGroundTruth

from .changes import Answer
from .interactive_image import InteractiveImage
from .label_model import Label, LabelStep, LabelStore
from .label_tool import SHAPES, LabelTool, label_from

if TYPE_CHECKING:
    from .main_window import DefinitionGUI

log = logging.getLogger(__name__)

#: The view labels are drawn on: the source's own picture.
INPUT_VIEW = "input"


class LabelMode(QObject):
    """The label mode of one definition window: its store, tool, toolbar and the File menu's label actions.

    ``truthChanged`` is emitted whenever the labels change (the quality strip rescores)."""

    truthChanged = Signal()  # noqa: N815 - Qt's signal naming

    def __init__(self, window: DefinitionGUI) -> None:
        super().__init__(window)
        self.window = window
        self.store = LabelStore(self)
        self.tool = LabelTool(self.labels, self._finished, self._select)
        #: The frame on screen and its key in the store.
        self.frame: Frame | None = None
        self.key: int | None = None
        self._view: InteractiveImage | None = None

        self.action = QAction("&Label frames", window, checkable=True)
        self.action.setShortcut(QKeySequence("Ctrl+L"))
        self.action.setToolTip("Mark the objects of each frame (drag boxes, click polygons) to measure the system")
        self.action.toggled.connect(self.set_active)
        self.open_action = QAction("Open &labels…", window)
        self.open_action.triggered.connect(lambda _=False: self.open())
        self.save_action = QAction("Save l&abels…", window)
        self.save_action.triggered.connect(lambda _=False: self.save())

        self.toolbar = QToolBar("Labels", window)
        self.toolbar.setObjectName("labels_toolbar")
        group = QActionGroup(self)
        self.shape_actions: dict[str, QAction] = {}
        for shape in SHAPES:
            action = QAction(shape.capitalize(), window, checkable=True)
            action.setChecked(shape == self.tool.shape)
            action.triggered.connect(lambda _=False, s=shape: self.set_shape(s))
            group.addAction(action)
            self.toolbar.addAction(action)
            self.shape_actions[shape] = action
        self.toolbar.addWidget(QLabel(" Name "))
        self.name_box = QComboBox()
        self.name_box.setEditable(True)
        self.name_box.setMinimumWidth(140)
        self.name_box.setToolTip("The name of the next label, and of the selected one when changed")
        self.name_box.lineEdit().editingFinished.connect(self._rename_selected)
        self.name_box.activated.connect(lambda _i: self._rename_selected())
        self.toolbar.addWidget(self.name_box)
        self.delete_action = QAction("Delete", window)
        self.delete_action.setShortcut(QKeySequence.StandardKey.Delete)
        self.delete_action.triggered.connect(lambda _=False: self.delete_selected())
        self.toolbar.addAction(self.delete_action)
        self.cancel_action = QAction("Drop shape", window)
        self.cancel_action.setShortcut(QKeySequence("Escape"))
        self.cancel_action.triggered.connect(lambda _=False: self._drop_shape())
        self.toolbar.addAction(self.cancel_action)
        self.count_label = QLabel()
        self.toolbar.addWidget(self.count_label)
        self.toolbar.setVisible(False)
        self.store.changed.connect(self._store_changed)
        window.frameShown.connect(lambda shown: self.show_frame(shown.results.frame))
        self._update_count()

    # -- state --------------------------------------------------------------------------------------------
    @property
    def active(self) -> bool:
        return self.action.isChecked()

    def set_active(self, on: bool) -> None:
        """Label mode on (the source pauses, the input view draws labels) or off (selection as before)."""
        if self.action.isChecked() != on:
            self.action.setChecked(on)  # toggled comes back here
            return
        self.toolbar.setVisible(on)
        if on:
            self.window.set_paused(True)
            self._fill_names()
        else:
            self.tool.cancel()
        self._attach()
        self.window.show_message("Label mode: drag a box or click a polygon's corners (double-click closes); "
                                 "Ctrl+click selects, Delete removes; step with the seek bar" if on
                                 else "Label mode off")

    def set_shape(self, shape: str) -> None:
        self.tool.cancel()
        self.tool.shape = shape
        self.shape_actions[shape].setChecked(True)

    def labels(self) -> tuple[Label, ...]:
        """The labels of the frame on screen."""
        return self.store.labels(self.key)

    @property
    def name(self) -> str:
        return self.name_box.currentText().strip() or self.window.system.object_name

    def _attach(self) -> None:
        """Give the tool to the input view on screen (views are rebuilt when the stages change)."""
        views = self.window.stage_views.views
        view = views.get(INPUT_VIEW) if self.active else None
        if self._view is not None and self._view is not view:
            self._view.tool = None
            self._view.update()
        if view is not None:
            view.tool = self.tool
            view.update()
        self._view = view

    def show_frame(self, frame: Frame) -> None:
        """A frame was put on screen: its labels are the ones drawn and edited now."""
        if frame is not self.frame:
            if self.frame is not None and self.store.key_of(frame) != self.key:
                self.tool.cancel()
                self.tool.selected = None
            self.frame = frame
            self.key = self.store.remember(frame)
            self._update_count()
        if self.active:
            self._attach()

    # -- edits (each an undo step) ---------------------------------------------------------------------------
    def _push(self, after: tuple[Label, ...], text: str) -> None:
        if self.key is None or self.frame is None:
            self.window.show_message("labels: this frame has no header stamp, and the labels are keyed by stamp",
                                     error=True)
            return
        before = self.store.labels(self.key) if self.key in self.store.keys else None
        self.window.undo.stack.push(LabelStep(self.store, self.key, before, after, text, self.frame))

    def _finished(self, points: list[QPointF], is_box: bool) -> None:
        label = label_from(points, is_box, self.name)
        if self.key is None and self.frame is not None:
            self.key = self.store.key_of(self.frame)
            if self.key is None:  # the set's keying, decided by a frame with a stamp: none here
                self.key = self.frame.index if self.frame.stamp_ns is None else self.frame.stamp_ns
        self._push((*self.labels(), label), f"label {label.name} ({'box' if is_box else 'polygon'})")
        self.tool.selected = len(self.labels()) - 1

    def _select(self, index: int | None) -> None:
        self.tool.selected = index
        if index is not None:
            self.name_box.setCurrentText(self.labels()[index].name)
        if self._view is not None:
            self._view.update()

    def delete_selected(self) -> None:
        labels, index = self.labels(), self.tool.selected
        if index is None or index >= len(labels):
            self.window.show_message("labels: nothing selected to delete (Ctrl+click a label)")
            return
        self.tool.selected = None
        self._push(labels[:index] + labels[index + 1:], f"delete label {labels[index].name}")

    def _rename_selected(self) -> None:
        labels, index, name = self.labels(), self.tool.selected, self.name
        if index is None or index >= len(labels) or labels[index].name == name:
            return
        old = labels[index]
        renamed = Label(name, old.box, old.polygon, old.group)
        self._push((*labels[:index], renamed, *labels[index + 1:]), f"rename label {old.name} to {name}")

    def _drop_shape(self) -> None:
        self.tool.cancel()
        if self._view is not None:
            self._view.update()

    def _store_changed(self) -> None:
        self._fill_names()
        self._update_count()
        if self._view is not None:
            self._view.update()
        self.truthChanged.emit()

    def _fill_names(self) -> None:
        current = self.name_box.currentText() or self.window.system.object_name
        names = [self.window.system.object_name, *[n for n in self.store.names if n != self.window.system.object_name]]
        if [self.name_box.itemText(i) for i in range(self.name_box.count())] != names:
            self.name_box.blockSignals(True)
            self.name_box.clear()
            self.name_box.addItems(names)
            self.name_box.blockSignals(False)
        self.name_box.setCurrentText(current)

    def _update_count(self) -> None:
        keyed = self.store.keyed_by or "index or stamp"
        unsaved = " *" if self.store.modified else ""
        self.count_label.setText(f"  {len(self.labels())} here, {len(self.store)} frames{unsaved}")
        self.count_label.setToolTip(f"{len(self.labels())} labels on this frame; {len(self.store)} frames labelled, "
                                    f"keyed by {keyed}{' (unsaved)' if unsaved else ''}")

    # -- files ----------------------------------------------------------------------------------------------
    def _kind(self) -> Kind | None:
        name = self.window.system.kind or self.window.worker.source_kind
        try:
            kind = get_kind(name) if name else None
        except Exception:  # an unknown kind: reported below like none
            kind = None
        if kind is None or not kind.truth_format:
            what = kind.title if kind is not None else "this pipeline's data"
            self.window.show_message(f"labels: {what} has no label file format", error=True)
            return None
        return kind

    def _ask_path(self, save: bool) -> str | None:
        folder = str(self.store.path or self.window.files.last_folder())
        title = "Save labels" if save else "Open labels"
        pattern = "Label files (*.json);;All files (*)"
        dialog = QFileDialog.getSaveFileName if save else QFileDialog.getOpenFileName
        path, _ = dialog(self.window, title, folder, pattern)
        return path or None

    def open(self, path: str | None = None) -> bool:
        """File > Open labels: replace the labels with those of a label file (unsaved ones asked about)."""
        kind = self._kind()
        if kind is None or not self.may_lose_labels("opening other labels"):
            return False
        path = path or self._ask_path(save=False)
        if path is None:
            return False
        try:
            truth = kind.read_truth(path)
        except (NoGroundTruth, ValueError, OSError) as exc:
            self.window.show_message(str(exc), error=True)
            return False
        self.store.load_truth(truth)
        self.key = self.store.remember(self.frame) if self.frame is not None else None
        self.window.show_message(f"labels: {len(truth)} frames from {path} (keyed by {truth.keyed_by})")
        return True

    def save(self, path: str | None = None) -> bool:
        """File > Save labels: write every label to a label file, atomically; True when saved."""
        kind = self._kind()
        if kind is None:
            return False
        path = path or self._ask_path(save=True)
        if path is None:
            return False
        try:
            kind.write_truth(path, self.store.to_truth(kind.name))
        except (NoGroundTruth, ValueError, OSError) as exc:
            self.window.show_message(f"labels not saved: {exc}", error=True)
            return False
        self.store.mark_saved(str(Path(path)))
        self.window.show_message(f"labels: {len(self.store)} frames saved to {path}")
        return True

    def may_lose_labels(self, what: str, ask: Callable[[str], Answer] | None = None) -> bool:
        """Before ``what`` would lose unsaved labels: True to go on (none, saved or discarded)."""
        if not self.store.modified:
            return True
        answer = (ask or self.window.changes.ask)(f"The labels have unsaved changes. Save them before {what}?")
        if answer is Answer.SAVE:
            return self.save(self.store.path)
        return answer is Answer.DISCARD

