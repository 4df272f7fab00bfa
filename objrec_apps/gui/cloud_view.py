"""CloudView: the interactive point-cloud view (orbit, zoom toward the cursor, pan, fit) with detected boxes.

It paints the software renderer's image (``cloud_render``) and draws each detected object's box (its
``Outline`` from the data kind), a small coordinate frame at its centre, a ground grid and the sensor's axes
with QPainter on top, so it needs no OpenGL and works offscreen. ``CloudInteraction`` holds what the
OpenGL view (``gl_cloud_view``) shares with it: the camera, the mouse and the overlays.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np
from PySide6.QtCore import QPointF, QRectF, QSize, Qt, QTimer, Signal
from PySide6.QtGui import QColor, QFont, QKeyEvent, QMouseEvent, QPainter, QPaintEvent, QPen, QWheelEvent
from PySide6.QtWidgets import QSizePolicy, QWidget

from objrec_core import Outline

from .cloud_render import (
    NEAR,
    CloudScene,
    OrbitCamera,
    clip_segment,
    frame_bounds,
    ground_grid,
    layer_colour,
    pick,
    pixel_point,
    render,
    rotate_about,
    zoom_toward,
)
from .images import ImageBuffer, rgb_qimage
from .label_placement import place_labels
from .render_path import RenderPath

BOX_COLOUR = QColor(255, 255, 0)
AXIS_COLOURS = (QColor(255, 60, 60), QColor(60, 255, 60), QColor(80, 140, 255))
GRID_COLOUR = QColor(110, 115, 125, 150)
#: Radians per pixel of mouse drag.
ROTATE_SPEED = 0.008
#: Distance factor of one wheel notch (120 eighths of a degree): small steps, 10% closer per notch.
ZOOM_STEP = 0.9
#: Seconds of paints the frame-rate label averages over.
FPS_WINDOW = 1.0
#: Points drawn while the camera moves (level of detail): a larger cloud is thinned to about this many while
#: it turns, pans or zooms (and the software view draws it at half the resolution), and drawn whole once it
#: stops. A 307,200-point frame costs the NumPy renderer about 26 ms of processor time at 800x600, thinned
#: to 76,800 at 400x300 about 4 ms.
MOVING_POINTS = 100_000
#: Milliseconds without a camera move after which the view counts as still and draws every point.
STILL_AFTER_MS = 150
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


def outlines_bounds(outlines: Sequence[Outline | None]) -> tuple[np.ndarray, np.ndarray] | None:
    """The box around every detected object's box corners (None without a box): what "fit to detections"
    shows and what the view orbits around."""
    corners = [np.asarray(o.box, dtype=np.float64) for o in outlines if o is not None and o.box is not None]
    corners = [c for c in corners if c.shape == (8, 3) and np.isfinite(c).all()]
    if not corners:
        return None
    every = np.vstack(corners)
    return every.min(axis=0), every.max(axis=0)


class CloudInteraction:
    """What both 3D views share: the camera, mouse and keys, the overlays (boxes, grid, axes, legend) and
    the measured frame rate. Left drag orbits (around the detections when ``orbit_detections`` and there
    are some), right or middle drag (or Shift + left) pans one to one, the wheel zooms toward the point
    under the cursor, a double click or R resets to the sensor's view, F fits the detections, A the cloud.

    Mixed into a QWidget subclass, which calls ``_init_interaction`` and defines ``viewChanged``."""

    camera: OrbitCamera
    scene: CloudScene
    outlines: list[Outline | None]

    def _init_interaction(self) -> None:
        self.camera = OrbitCamera()
        self.scene = CloudScene()
        #: One outline per detected object, in the detection list's order (None: nothing to draw).
        self.outlines = []
        #: Where the detections' names were written in the last frame drawn (tests look).
        self.label_rects: list[QRectF] = []
        self.point_size = 1
        self.hidden: frozenset[int] = frozenset()
        self.show_grid = True
        self.orbit_detections = True
        #: Text drawn over the view while it waits for data (a cloud loading, a pipeline turning 3D).
        self.busy_text = ""
        self._fitted = False
        self._drag: tuple[QPointF, Qt.MouseButton, Qt.KeyboardModifier, float] | None = None
        self._paint_times: deque[float] = deque(maxlen=600)
        self._frames_drawn = 0
        self._grid_cache: tuple[Any, np.ndarray, float] | None = None
        #: Milliseconds the last frame took to draw (points and overlays).
        self.frame_ms = 0.0
        #: Which renderer this is and why (``make_cloud_view`` sets the machine's choice).
        self.render_path = RenderPath(self.uses_opengl, "made directly")  # type: ignore[attr-defined]
        #: Level of detail: while the camera moves, at most about this many points are drawn (0: always all).
        self.moving_points = MOVING_POINTS
        #: The camera is being moved (a drag, the wheel): the thinned cloud is drawn until it stops.
        self.moving = False
        #: Frames drawn thinned and whole (tests and the benchmark count them).
        self.thinned_frames = 0
        self.whole_frames = 0
        self._still_timer = QTimer(self)  # type: ignore[arg-type]
        self._still_timer.setSingleShot(True)
        self._still_timer.setInterval(STILL_AFTER_MS)
        self._still_timer.timeout.connect(self.stop_moving)
        self.setMinimumSize(320, 240)  # type: ignore[attr-defined]
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)  # type: ignore[attr-defined]
        self.setFocusPolicy(Qt.FocusPolicy.StrongFocus)  # type: ignore[attr-defined]
        self.setToolTip(  # type: ignore[attr-defined]
            "Drag: orbit · right drag or Shift+drag: pan · wheel: zoom toward the cursor · "
            "F: fit to detections · A: fit to cloud · double click or R: sensor view")

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
        self._scene_changed()
        self.update()  # type: ignore[attr-defined]

    def _scene_changed(self) -> None:
        """Hook: the points changed (the OpenGL view uploads them again)."""

    def _aspect(self) -> float:
        return self.width() / max(self.height(), 1)  # type: ignore[attr-defined]

    def reset_view(self) -> None:
        self.camera.fit(self.scene.bounds(), self._aspect())
        self._fitted = self.scene.points.shape[0] > 0
        self._changed()

    def fit_to_cloud(self) -> None:
        """See the whole cloud from the direction looked from now."""
        frame_bounds(self.camera, self.scene.bounds(), self._aspect())
        self._changed()

    def fit_to_detections(self) -> bool:
        """See every detected box, from the direction looked from now; False when there is none."""
        bounds = outlines_bounds(self.outlines)
        if bounds is None:
            return False
        frame_bounds(self.camera, bounds, self._aspect())
        self._changed()
        return True

    def orbit_pivot(self) -> np.ndarray | None:
        """The point left drags turn around: the detections' centre when orbiting them, else the target."""
        if not self.orbit_detections:
            return None
        bounds = outlines_bounds(self.outlines)
        return None if bounds is None else (bounds[0] + bounds[1]) / 2.0

    def set_point_size(self, size: int) -> None:
        self.point_size = max(1, min(int(size), 4))
        self._changed()

    def set_hidden(self, hidden: frozenset[int]) -> None:
        self.hidden = frozenset(hidden)
        self._changed()

    def set_grid(self, shown: bool) -> None:
        self.show_grid = bool(shown)
        self._changed()

    def set_orbit_detections(self, on: bool) -> None:
        self.orbit_detections = bool(on)

    def set_busy(self, text: str) -> None:
        """Show ``text`` over the view with a moving mark until ``set_busy("")``."""
        self.busy_text = text
        self.update()  # type: ignore[attr-defined]

    def _changed(self) -> None:
        self.update()  # type: ignore[attr-defined]
        self.viewChanged.emit()  # type: ignore[attr-defined]

    # -- level of detail ------------------------------------------------------------------------------
    def start_moving(self) -> None:
        """The camera moves (called on every drag step and wheel notch): draw thinned until it stops for
        ``STILL_AFTER_MS``."""
        self.moving = True
        self._still_timer.start()

    def stop_moving(self) -> None:
        """The camera stopped: draw the whole cloud again."""
        self._still_timer.stop()
        if self.moving:
            self.moving = False
            self.update()  # type: ignore[attr-defined]

    def drawn_scene(self) -> CloudScene:
        """The scene to draw now: thinned while the camera moves (and counted), else the whole one."""
        if self.moving and self.moving_points > 0:
            thin = self.scene.thinned(self.moving_points)
            if thin is not self.scene:
                return thin
        return self.scene

    def _count_detail(self, scene: CloudScene) -> None:
        if scene is self.scene:
            self.whole_frames += 1
        else:
            self.thinned_frames += 1

    # -- frame rate -----------------------------------------------------------------------------------
    def _count_frame(self, started: float) -> None:
        now = time.perf_counter()
        self.frame_ms = (now - started) * 1000.0
        self._paint_times.append(now)
        self._frames_drawn += 1

    def frames_per_second(self, now: float | None = None) -> float:
        """Frames drawn per second over the last second: 0 when nothing was drawn in it (nothing moves)."""
        now = time.perf_counter() if now is None else now
        recent = [t for t in self._paint_times if now - t <= FPS_WINDOW]
        if len(recent) < 2:
            return 0.0
        return (len(recent) - 1) / max(recent[-1] - recent[0], 1e-6)

    @property
    def frames_drawn(self) -> int:
        """Frames drawn since the view was made (the rate's window keeps only the last 600 times)."""
        return self._frames_drawn

    # -- overlays -------------------------------------------------------------------------------------
    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.camera.project(points, self.width(), self.height())  # type: ignore[attr-defined]

    def draw_overlays(self, painter: QPainter) -> None:
        painter.setRenderHint(QPainter.RenderHint.Antialiasing)
        if self.show_grid:
            self._draw_grid(painter)
        labels: list[tuple[np.ndarray, str]] = []
        for number, outline in enumerate(self.outlines, 1):
            if outline is not None and outline.box is not None:
                label = self._draw_box(painter, outline, number)
                if label is not None:
                    labels.append(label)
        self._draw_labels(painter, labels)
        self._draw_legend(painter)
        if self.busy_text:
            self._draw_busy(painter)

    def _segment(self, painter: QPainter, a: np.ndarray, b: np.ndarray) -> None:
        ends = clip_segment(self.camera, a, b, self.width(), self.height())  # type: ignore[attr-defined]
        if ends is not None:
            painter.drawLine(QPointF(*ends[0]), QPointF(*ends[1]))

    def _draw_grid(self, painter: QPainter) -> None:
        """The ground grid under the cloud and the sensor's axes at the origin (x red, y green, z blue)."""
        bounds = self.scene.bounds()
        key = id(self.scene)
        if self._grid_cache is None or self._grid_cache[0] != key:
            segments, step = ground_grid(bounds)
            self._grid_cache = (key, segments, step)
        _, segments, step = self._grid_cache
        painter.setPen(QPen(GRID_COLOUR, 1))
        for a, b in segments:
            self._segment(painter, a, b)
        origin = np.zeros(3)
        painter.setFont(QFont(painter.font().family(), 8))
        for axis, name in enumerate("xyz"):
            end = np.zeros(3)
            end[axis] = 2 * step
            painter.setPen(QPen(AXIS_COLOURS[axis], 2))
            self._segment(painter, origin, end)
            uv, depth = self.project(end[None, :])
            if depth[0] > NEAR:
                painter.drawText(QPointF(uv[0, 0] + 3, uv[0, 1] - 3), name)
        painter.setPen(QPen(GRID_COLOUR.lighter(150)))
        painter.drawText(QPointF(8, self.height() - 8), f"grid {step:g} m")  # type: ignore[attr-defined]

    def _line(self, painter: QPainter, a: np.ndarray, b: np.ndarray, da: float, db: float) -> None:
        if da > NEAR and db > NEAR:
            painter.drawLine(QPointF(*a), QPointF(*b))

    def _draw_box(self, painter: QPainter, outline: Outline, number: int) -> tuple[np.ndarray, str] | None:
        """The box and its axes; where its label goes (above the box's top corner) and what it says, None when
        the box is behind the camera."""
        geometry = box_frame(outline.box)
        if geometry is None:
            return None
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
        if depth_axes[0] <= NEAR:
            return None
        top = uv[np.argmin(uv[:, 1])] if np.all(depth > NEAR) else uv_axes[0]
        return top + np.array([4.0, -4.0]), f"{number}: {outline.label}"

    def _draw_labels(self, painter: QPainter, labels: list[tuple[np.ndarray, str]]) -> None:
        """The detections' names, after every box, none over another nor past the view's edge."""
        self.label_rects = []
        if not labels:
            return
        painter.setPen(QPen(BOX_COLOUR))
        painter.setFont(QFont(painter.font().family(), 9))
        metrics = painter.fontMetrics()
        sizes = [(float(metrics.horizontalAdvance(text) + 2), float(metrics.height())) for _, text in labels]
        anchors = [(float(at[0]), float(at[1])) for at, _ in labels]
        width, height = float(self.width()), float(self.height())  # type: ignore[attr-defined]
        self.label_rects = place_labels(anchors, sizes, width, height)
        for rect, (_, text) in zip(self.label_rects, labels, strict=True):
            painter.drawText(rect, int(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter), text)

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

    def _draw_busy(self, painter: QPainter) -> None:
        """A banner with a turning arc: the view is waiting, not broken."""
        width, height = self.width(), self.height()  # type: ignore[attr-defined]
        box = QRectF(width / 2 - 170, height / 2 - 22, 340, 44)
        painter.fillRect(box, QColor(0, 0, 0, 170))
        painter.setPen(QPen(QColor(120, 190, 255), 3))
        angle = int((time.perf_counter() * 360) % 360) * 16
        painter.drawArc(QRectF(box.left() + 12, box.top() + 10, 24, 24), angle, 270 * 16)
        painter.setPen(QPen(QColor(235, 235, 235)))
        painter.setFont(QFont(painter.font().family(), 10))
        painter.drawText(box.adjusted(46, 0, -8, 0), int(Qt.AlignmentFlag.AlignVCenter), self.busy_text)

    # -- interaction ------------------------------------------------------------------------------------
    def _under_cursor(self, position: QPointF) -> np.ndarray | None:
        visible = self.scene.points
        if self.hidden and visible.shape[0]:
            visible = visible[~np.isin(self.scene.owner, list(self.hidden))]
        return pick(self.camera, visible, position.x(), position.y(), self.width(), self.height())  # type: ignore[attr-defined]

    def _depth_under(self, position: QPointF) -> float:
        """Depth of the point under the cursor (the target's when none): a pan moves that point one to one."""
        point = self._under_cursor(position)
        if point is None:
            return self.camera.distance
        depth = float(self.camera.rotation()[2] @ (point - self.camera.position()))
        return depth if depth > NEAR else self.camera.distance

    def mousePressEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        pan = self._is_pan(event.button(), event.modifiers())
        depth = self._depth_under(event.position()) if pan else self.camera.distance
        self._drag = (event.position(), event.button(), event.modifiers(), depth)

    @staticmethod
    def _is_pan(button: Qt.MouseButton, modifiers: Qt.KeyboardModifier) -> bool:
        return button in (Qt.MouseButton.RightButton, Qt.MouseButton.MiddleButton) or bool(
            modifiers & Qt.KeyboardModifier.ShiftModifier)

    def mouseMoveEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        if self._drag is None:
            return
        start, button, modifiers, depth = self._drag
        delta = event.position() - start
        if self._is_pan(button, modifiers):
            self.camera.pan(delta.x() * depth / self.camera.distance, delta.y() * depth / self.camera.distance,
                            self.height())  # type: ignore[attr-defined]
        else:
            pivot = self.orbit_pivot()
            d_yaw, d_pitch = delta.x() * ROTATE_SPEED, -delta.y() * ROTATE_SPEED
            if pivot is None:
                self.camera.rotate(d_yaw, d_pitch)
            else:
                rotate_about(self.camera, d_yaw, d_pitch, pivot)
        self._drag = (event.position(), button, modifiers, depth)
        self.start_moving()
        self._changed()

    def mouseReleaseEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        self._drag = None
        self.stop_moving()

    def mouseDoubleClickEvent(self, event: QMouseEvent) -> None:  # noqa: N802 - Qt override
        self.reset_view()

    def zoom_at(self, position: QPointF, steps: float) -> None:
        """Zoom ``steps`` notches (positive: closer) toward the spot under ``position``, at the depth of what
        is drawn there (the target's depth where nothing is), so that spot stays under the cursor."""
        point = pixel_point(self.camera, position.x(), position.y(), self.width(), self.height(),  # type: ignore[attr-defined]
                            self._depth_under(position))
        zoom_toward(self.camera, ZOOM_STEP**steps, point)
        self._changed()

    def wheelEvent(self, event: QWheelEvent) -> None:  # noqa: N802 - Qt override
        steps = event.angleDelta().y() / 120.0
        if steps:
            self.start_moving()
            self.zoom_at(event.position(), steps)

    def keyPressEvent(self, event: QKeyEvent) -> None:  # noqa: N802 - Qt override
        key = event.key()
        centre = QPointF(self.width() / 2.0, self.height() / 2.0)  # type: ignore[attr-defined]
        if key == Qt.Key.Key_R:
            self.reset_view()
        elif key == Qt.Key.Key_F:
            self.fit_to_detections()
        elif key == Qt.Key.Key_A:
            self.fit_to_cloud()
        elif key in (Qt.Key.Key_Plus, Qt.Key.Key_Equal):
            self.zoom_at(centre, 1)
        elif key == Qt.Key.Key_Minus:
            self.zoom_at(centre, -1)
        else:
            super().keyPressEvent(event)  # type: ignore[misc]


class CloudView(CloudInteraction, QWidget):
    """The 3D view drawn by the NumPy renderer: works anywhere Qt does (offscreen, no GPU)."""

    viewChanged = Signal()  # noqa: N815 - Qt's signal naming

    def __init__(self, parent: QWidget | None = None) -> None:
        QWidget.__init__(self, parent)
        self._init_interaction()
        self._cache: tuple[Any, ImageBuffer] | None = None
        self.setAttribute(Qt.WidgetAttribute.WA_OpaquePaintEvent)

    @property
    def uses_opengl(self) -> bool:
        return False

    def _scene_changed(self) -> None:
        self._cache = None

    def _changed(self) -> None:
        self._cache = None
        super()._changed()

    def render_image(self) -> ImageBuffer:
        """The cloud rendered at the widget's size (half of it while the camera moves a large cloud); cached
        until the scene, view or size changes."""
        c = self.camera
        scene = self.drawn_scene()
        # Thinned while moving, and at half the resolution (scaled up when painted): a quarter of the pixels
        # to clear and fill, so a loaded 2-core machine still turns the cloud smoothly.
        scale = 1 if scene is self.scene else 2
        width, height = max(self.width() // scale, 1), max(self.height() // scale, 1)
        size = max(self.point_size // scale, 1)
        key = (id(scene), width, height, tuple(c.target), c.distance, c.yaw, c.pitch, size, self.hidden)
        if self._cache is None or self._cache[0] != key:
            rgb = render(scene, c, width, height, point_size=size, hidden=self.hidden)
            self._cache = (key, rgb_qimage(rgb))
            self._count_detail(scene)
        return self._cache[1]

    def paintEvent(self, event: QPaintEvent) -> None:  # noqa: N802 - Qt override
        started = time.perf_counter()
        painter = QPainter(self)
        image = self.render_image().qimage
        if image.width() == self.width():
            painter.drawImage(0, 0, image)
        else:  # the half-resolution image of a moving view, scaled up
            painter.drawImage(self.rect(), image)
        self.draw_overlays(painter)
        painter.end()
        self._count_frame(started)
