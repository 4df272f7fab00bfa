"""The 3D page of the window, for data kinds whose views show points (``Kind.has_points``): layer toggles,
the cloud view and the list of detections. Points and boxes come from the kind (``points``, ``outlines``)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QCheckBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QProgressBar,
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
from .cloud_view import box_frame
from .flow_layout import FlowLayout
from .gl_cloud_view import make_cloud_view

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
    """Controls (reset, fits, grid, orbit centre, point size, which layers to draw), the cloud view (OpenGL
    where it works, else the software one), the measured frame rate, a busy bar while waiting for data, and
    the DetectionsTable."""

    def __init__(self, parent: QWidget | None = None, prefer_gl: bool | None = None) -> None:
        super().__init__(parent)
        self.cloud_view = make_cloud_view(prefer_gl=prefer_gl)
        self.table = DetectionsTable()
        # The controls wrap into rows (flow_layout.py): a row of them side by side made a 3D pipeline's window
        # wider than a 1280 px laptop screen.
        self.controls = QWidget()
        controls = FlowLayout(self.controls)
        reset = QPushButton("Reset view")
        reset.setToolTip("Back to the sensor's view of the whole cloud (also: double click, or R)")
        reset.clicked.connect(self.cloud_view.reset_view)
        controls.addWidget(reset)
        self.fit_detections = QPushButton("Fit to detections")
        self.fit_detections.setToolTip("Frame every detected box, from the direction you look from now (F)")
        self.fit_detections.clicked.connect(self.cloud_view.fit_to_detections)
        controls.addWidget(self.fit_detections)
        self.fit_cloud = QPushButton("Fit to cloud")
        self.fit_cloud.setToolTip("Frame the whole cloud, from the direction you look from now (A)")
        self.fit_cloud.clicked.connect(self.cloud_view.fit_to_cloud)
        controls.addWidget(self.fit_cloud)
        self.orbit = QCheckBox("Orbit detections")
        self.orbit.setToolTip("Dragging turns the view around the detected objects' centre (else around the "
                              "middle of the view)")
        self.orbit.setChecked(self.cloud_view.orbit_detections)
        self.orbit.toggled.connect(self.cloud_view.set_orbit_detections)
        controls.addWidget(self.orbit)
        self.grid = QCheckBox("Grid")
        self.grid.setToolTip("A ground grid under the cloud and the sensor's axes (x red, y green, z blue)")
        self.grid.setChecked(self.cloud_view.show_grid)
        self.grid.toggled.connect(self.cloud_view.set_grid)
        controls.addWidget(self.grid)
        size_box = QWidget()  # the label and its spin box stay on one row
        size_row = QHBoxLayout(size_box)
        size_row.setContentsMargins(0, 0, 0, 0)
        size_row.addWidget(QLabel("Point size"))
        self.point_size = QSpinBox()
        self.point_size.setRange(1, 4)
        self.point_size.setValue(self.cloud_view.point_size)
        self.point_size.valueChanged.connect(self.cloud_view.set_point_size)
        size_row.addWidget(self.point_size)
        controls.addWidget(size_box)
        #: The layer check boxes go into the flow here, one per layer.
        self.layer_box = controls
        self._layers_at = controls.count()
        self.busy = QProgressBar()
        self.busy.setRange(0, 0)  # a moving bar: how long is not known
        self.busy.setMaximumWidth(120)
        self.busy.setTextVisible(False)
        self.busy.hide()
        controls.addWidget(self.busy)
        self.summary = QLabel()
        controls.addWidget(self.summary)
        self.fps_label = QLabel()
        path = self.cloud_view.render_path
        self.fps_label.setToolTip(f"Frames the 3D view really drew in the last second, and the time of the last "
                                  f"one. Drawn by the {path.name}: {path.reason}. objrec-define --renderer "
                                  f"opengl or software (or OBJREC_RENDERER) overrides the choice. While the "
                                  f"view turns, a large cloud is thinned; it is drawn whole once the view stops.")
        controls.addWidget(self.fps_label)
        self._fps_timer = QTimer(self)
        self._fps_timer.setInterval(500)
        self._fps_timer.timeout.connect(self.update_rate)
        self._fps_timer.start()
        self._layer_checks: list[QCheckBox] = []
        #: The thinning step of the coarse preview on screen (0: a full result), and how many of each were shown.
        self.preview_step = 0
        self.previews_shown = 0
        self.full_results_shown = 0
        splitter = QSplitter(Qt.Orientation.Vertical)
        splitter.addWidget(self.cloud_view)
        splitter.addWidget(self.table)
        splitter.setStretchFactor(0, 4)
        splitter.setStretchFactor(1, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.controls)
        layout.addWidget(splitter, 1)

    def update_rate(self) -> None:
        """The frame-rate label: measured paints, not a target (0 while nothing moves)."""
        view = self.cloud_view
        self.fps_label.setText(f"{view.frames_per_second():.0f} fps · {view.frame_ms:.0f} ms"
                               f"{' · GL' if view.uses_opengl else ''}")
        if self.is_busy:
            view.update()  # keeps the busy mark turning

    @property
    def is_busy(self) -> bool:
        return bool(self.cloud_view.busy_text)

    def set_busy(self, text: str) -> None:
        """Say what the view waits for (a cloud loading, a pipeline's first 3D frame) until a frame comes;
        "" ends it."""
        self.cloud_view.set_busy(text)
        self.busy.setVisible(bool(text))
        self.busy.setToolTip(text)

    def show_results(self, results: StageResults, kind: Kind, scene: CloudScene | None = None,
                     preview_step: int = 0) -> None:
        """Show a frame of data ``kind``; ``scene`` when already merged (by the worker thread). ``preview_step``
        k > 0 marks a coarse preview made on every k-th row and column (preview.py): it is said so until the
        full result replaces it."""
        if self.is_busy:
            self.set_busy("")
        scene = scene if scene is not None else prepare_scene(results, kind)
        self._sync_layers(scene.names)
        objects = list(results.objects.objects)
        outlines = object_outlines(kind, results.objects)
        self.cloud_view.set_scene(scene, outlines)
        self.table.show_objects(objects, outlines)
        self.preview_step = preview_step
        if preview_step:
            self.previews_shown += 1
            self.summary.setText(f"preview (1/{preview_step * preview_step} of the points) · {len(objects)} "
                                 f"detected · {results.seconds * 1000:.0f} ms")
            self.summary.setToolTip("A coarse preview of the new values, on a thinned cloud: the full result "
                                    "replaces it when it is ready")
        else:
            self.full_results_shown += 1
            self.summary.setText(f"{len(objects)} detected · {results.seconds * 1000:.0f} ms")
            self.summary.setToolTip("Objects detected in the frame on screen, and the pipeline's time for it")

    def clear(self, waiting: str = "waiting for the first frame…") -> None:
        """Empty the view; it shows ``waiting`` (busy) until the next frame."""
        self.cloud_view.set_scene(CloudScene(), [])
        self.table.show_objects([], [])
        self.summary.setText("")
        self.set_busy(waiting)

    def _sync_layers(self, names: list[str]) -> None:
        if [c.text() for c in self._layer_checks] == names:
            return
        for check in self._layer_checks:
            self.layer_box.removeWidget(check)
            check.deleteLater()
        self._layer_checks = []
        for index, name in enumerate(names):
            check = QCheckBox(name)
            check.setToolTip(f"Show the {name} layer")
            check.setChecked(index not in self.cloud_view.hidden)
            r, g, b = layer_colour(index)
            check.setStyleSheet(f"QCheckBox {{ color: {QColor(r, g, b).darker(130).name()}; font-weight: bold; }}")
            check.toggled.connect(self._layers_toggled)
            self.layer_box.insert_widget(self._layers_at + index, check)
            self._layer_checks.append(check)

    def _layers_toggled(self) -> None:
        hidden = frozenset(i for i, c in enumerate(self._layer_checks) if not c.isChecked())
        self.cloud_view.set_hidden(hidden)
