"""The 3D page of the window, for data kinds whose views show points (``Kind.has_points``): layer toggles,
the cloud view and the list of detections. Points and boxes come from the kind (``points``, ``outlines``)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QCheckBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QPushButton,
    QSpinBox,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from objrec_core import DetectedObjectArray, Kind, Outline, StageResults

from .cloud_render import CloudScene, layer_colour
from .cloud_view import CloudView, box_frame

log = logging.getLogger(__name__)

COLUMNS = ("#", "name", "shape", "radius (m)", "x", "y", "z", "width × height × depth (m)", "inliers")


def cloud_layers(results: StageResults, kind: Kind) -> list[tuple[str, Any]]:
    """The layers to draw, as the kind's N x 3 points: the original, then every filter's output, named as the
    stages are. An output the kind has no points for is left out (and logged)."""
    layers = []
    for stage in results.stages:
        if stage.role not in ("input", "filter"):
            continue
        try:
            points = kind.points(stage.output)
        except Exception as exc:  # a filter output of another kind: the other layers still show
            log.debug("stage %s has no points to show: %s", stage.id, exc)
            continue
        if points is not None:
            layers.append(("original" if stage.role == "input" else stage.id, points))
    return layers


def prepare_scene(results: StageResults, kind: Kind) -> CloudScene:
    """Done in the processing thread, so the GUI thread only renders."""
    return CloudScene.from_layers(cloud_layers(results, kind))


def object_outlines(kind: Kind, objects: DetectedObjectArray) -> list[Outline | None]:
    """Each detected object's outline from the kind, in the objects' order (None where it gives none)."""
    found: list[Outline | None] = []
    for obj in objects.objects:
        one = kind.outlines(type(objects)(header=objects.header, objects=[obj]))
        found.append(one[0] if one else None)
    return found


class DetectionsTable(QTableWidget):
    """One row per detection: its name, the shape, radius and inliers where its message has them, and the
    centre and sides of its box outline."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(0, len(COLUMNS), parent)
        self.setHorizontalHeaderLabels(list(COLUMNS))
        self.verticalHeader().hide()
        self.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QTableWidget.SelectionBehavior.SelectRows)
        self.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.horizontalHeader().setStretchLastSection(True)

    def show_objects(self, objects: Sequence[Any], outlines: Sequence[Outline | None]) -> None:
        self.setRowCount(len(objects))
        for row, (obj, outline) in enumerate(zip(objects, outlines, strict=True)):
            geometry = box_frame(outline.box) if outline is not None and outline.box is not None else None
            centre, sides = (geometry[0], geometry[2]) if geometry else ((float("nan"),) * 3, (float("nan"),) * 3)
            radius = getattr(obj, "radius", None)
            cells = [
                str(row + 1),
                str(getattr(obj, "name", "")),
                str(getattr(obj, "shape", "") or "-"),
                f"{radius:.4f}" if isinstance(radius, float) and radius > 0 else "-",
                *(f"{c:+.3f}" for c in centre),
                " × ".join(f"{s:.3f}" for s in sides),
                str(getattr(obj, "inliers", "") or "-"),
            ]
            for column, text in enumerate(cells):
                item = QTableWidgetItem(text)
                if column not in (1, 2, 7):
                    item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                self.setItem(row, column, item)


class View3D(QWidget):
    """Controls (reset, point size, which layers to draw), the CloudView and the DetectionsTable."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.cloud_view = CloudView()
        self.table = DetectionsTable()
        controls = QHBoxLayout()
        reset = QPushButton("Reset view")
        reset.setToolTip("Back to the sensor's view of the whole cloud (also: double click, or R)")
        reset.clicked.connect(self.cloud_view.reset_view)
        controls.addWidget(reset)
        controls.addWidget(QLabel("Point size"))
        self.point_size = QSpinBox()
        self.point_size.setRange(1, 4)
        self.point_size.setValue(self.cloud_view.point_size)
        self.point_size.valueChanged.connect(self.cloud_view.set_point_size)
        controls.addWidget(self.point_size)
        self.layer_box = QHBoxLayout()
        controls.addLayout(self.layer_box)
        controls.addStretch(1)
        self.summary = QLabel()
        controls.addWidget(self.summary)
        self._layer_checks: list[QCheckBox] = []
        splitter = QSplitter(Qt.Orientation.Vertical)
        splitter.addWidget(self.cloud_view)
        splitter.addWidget(self.table)
        splitter.setStretchFactor(0, 4)
        splitter.setStretchFactor(1, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(controls)
        layout.addWidget(splitter, 1)

    def show_results(self, results: StageResults, kind: Kind, scene: CloudScene | None = None) -> None:
        """Show a frame of data ``kind``; ``scene`` when already merged (by the worker thread)."""
        scene = scene if scene is not None else prepare_scene(results, kind)
        self._sync_layers(scene.names)
        objects = list(results.objects.objects)
        outlines = object_outlines(kind, results.objects)
        self.cloud_view.set_scene(scene, outlines)
        self.table.show_objects(objects, outlines)
        self.summary.setText(f"{len(objects)} detected · {results.seconds * 1000:.0f} ms")

    def clear(self) -> None:
        self.cloud_view.set_scene(CloudScene(), [])
        self.table.show_objects([], [])
        self.summary.setText("")

    def _sync_layers(self, names: list[str]) -> None:
        if [c.text() for c in self._layer_checks] == names:
            return
        for check in self._layer_checks:
            self.layer_box.removeWidget(check)
            check.deleteLater()
        self._layer_checks = []
        for index, name in enumerate(names):
            check = QCheckBox(name)
            check.setChecked(index not in self.cloud_view.hidden)
            r, g, b = layer_colour(index)
            check.setStyleSheet(f"QCheckBox {{ color: {QColor(r, g, b).darker(130).name()}; font-weight: bold; }}")
            check.toggled.connect(self._layers_toggled)
            self.layer_box.addWidget(check)
            self._layer_checks.append(check)

    def _layers_toggled(self) -> None:
        hidden = frozenset(i for i, c in enumerate(self._layer_checks) if not c.isChecked())
        self.cloud_view.set_hidden(hidden)
