"""GLCloudView: the 3D view drawn by OpenGL (a QOpenGLWidget with vertex buffers), for turning large clouds
smoothly where a GPU or Mesa is present; ``make_cloud_view`` picks it, or the NumPy ``CloudView`` where
OpenGL is missing (the offscreen platform, a failed context, or ``OBJREC_GL=0``) or drawn by the processor
(Mesa's llvmpipe: ``render_path.py`` chooses).

The points go to the GPU once per frame of data (interleaved positions and layer colours); turning the
view only changes a matrix, so each frame costs the GPU's (or Mesa llvmpipe's) point drawing and nothing in
Python. Depth shading is done in the vertex shader as the software renderer does it; hidden layers are left
out of the upload; boxes, grid, axes and the legend are the shared QPainter overlays.
"""

from __future__ import annotations

import logging
import math
import os
import time

import numpy as np
from PySide6.QtCore import Signal
from PySide6.QtGui import QGuiApplication, QMatrix4x4, QOpenGLContext, QOpenGLFunctions, QPainter, QSurfaceFormat
from PySide6.QtOpenGL import QOpenGLBuffer, QOpenGLShader, QOpenGLShaderProgram, QOpenGLVertexArrayObject
from PySide6.QtOpenGLWidgets import QOpenGLWidget
from PySide6.QtWidgets import QWidget

from .cloud_render import BACKGROUND, NEAR, layer_colour
from .cloud_view import CloudInteraction, CloudView
from .render_path import NO_GL_PLATFORMS, RenderPath, choose_render_path

log = logging.getLogger(__name__)

GL_COLOR_BUFFER_BIT = 0x4000
GL_DEPTH_BUFFER_BIT = 0x0100
GL_DEPTH_TEST = 0x0B71
GL_PROGRAM_POINT_SIZE = 0x8642
GL_POINTS = 0x0000
GL_FLOAT = 0x1406
GL_UNSIGNED_BYTE = 0x1401

VERTEX_SHADER = """
#version 120
attribute vec3 position;
attribute vec3 layer_colour;
uniform mat4 mvp;
uniform vec3 forward;
uniform vec3 eye;
uniform float near_depth;
uniform float depth_scale;
uniform float point_size;
varying vec3 colour;
void main() {
    float t = clamp((dot(position - eye, forward) - near_depth) * depth_scale, 0.0, 1.0);
    colour = layer_colour * (1.0 - 0.55 * t);
    gl_Position = mvp * vec4(position, 1.0);
    gl_PointSize = point_size;
}
"""

FRAGMENT_SHADER = """
#version 120
varying vec3 colour;
void main() {
    gl_FragColor = vec4(colour, 1.0);
}
"""


def gl_available() -> bool:
    """Whether an OpenGL view can work here: a platform with OpenGL, a context that can be created, and
    not turned off with ``OBJREC_GL=0``."""
    if os.environ.get("OBJREC_GL", "1") == "0":
        return False
    if QGuiApplication.platformName() in NO_GL_PLATFORMS:
        return False
    context = QOpenGLContext()
    return bool(context.create())


def make_cloud_view(parent: QWidget | None = None, prefer_gl: bool | None = None) -> CloudView | GLCloudView:
    """The faster view for this machine (``prefer_gl`` None: ``render_path.choose_render_path``, from the
    OpenGL renderer's name and ``OBJREC_RENDERER``), else OpenGL where it can work (True) or the software
    one (False). The view's ``render_path`` says which and why."""
    if prefer_gl is None:
        path = choose_render_path()
    elif prefer_gl and gl_available():
        path = RenderPath(True, "asked for by the caller")
    else:
        path = RenderPath(False, "asked for by the caller" if not prefer_gl else "no OpenGL here")
    view = GLCloudView(parent) if path.opengl else CloudView(parent)
    view.render_path = path
    return view


def projection_matrix(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    """Camera frame (x right, y down, z forward, as ``OrbitCamera``) to OpenGL clip space."""
    f = 1.0 / math.tan(fov_y / 2.0)
    return np.array([
        [f / aspect, 0.0, 0.0, 0.0],
        [0.0, -f, 0.0, 0.0],
        [0.0, 0.0, (far + near) / (far - near), -2.0 * far * near / (far - near)],
        [0.0, 0.0, 1.0, 0.0],
    ])


class GLCloudView(CloudInteraction, QOpenGLWidget):
    """The 3D view on the GPU; same behaviour and overlays as ``CloudView``."""

    viewChanged = Signal()  # noqa: N815 - Qt's signal naming

    def __init__(self, parent: QWidget | None = None) -> None:
        QOpenGLWidget.__init__(self, parent)
        surface = QSurfaceFormat()
        surface.setDepthBufferSize(24)
        surface.setSwapInterval(0)  # frames as fast as they are drawn: the rate label tells the truth
        self.setFormat(surface)
        self._init_interaction()
        self._program: QOpenGLShaderProgram | None = None
        self._vao: QOpenGLVertexArrayObject | None = None
        self._vertices: QOpenGLBuffer | None = None
        self._uploaded: tuple[int, frozenset[int]] | None = None  # the scene and hidden layers in the buffers
        self._count = 0
        self._thinned_count = 0
        self.gl_failed = ""

    @property
    def uses_opengl(self) -> bool:
        return True

    # -- OpenGL ------------------------------------------------------------------------------------------
    def initializeGL(self) -> None:  # noqa: N802 - Qt override
        program = QOpenGLShaderProgram(self)
        ok = program.addShaderFromSourceCode(QOpenGLShader.ShaderTypeBit.Vertex, VERTEX_SHADER)
        ok = ok and program.addShaderFromSourceCode(QOpenGLShader.ShaderTypeBit.Fragment, FRAGMENT_SHADER)
        program.bindAttributeLocation("position", 0)
        program.bindAttributeLocation("layer_colour", 1)
        if not (ok and program.link()):
            self.gl_failed = program.log()
            log.error("the OpenGL cloud view cannot draw: %s", self.gl_failed)
            return
        self._program = program
        self._vao = QOpenGLVertexArrayObject(self)
        self._vao.create()
        self._vertices = QOpenGLBuffer(QOpenGLBuffer.Type.VertexBuffer)
        self._vertices.create()
        self._uploaded = None

    def _upload(self) -> None:
        """Send the shown layers' points and colours to the GPU: once per frame of data or change of hidden
        layers, never while turning. Per-point colours keep the vertex shader short, which is what limits a
        software OpenGL (Mesa's llvmpipe) on large clouds."""
        assert self._vertices is not None and self._vao is not None
        program = self._program
        assert program is not None
        points, owner = self.scene.points, self.scene.owner
        if self.hidden and points.shape[0]:
            keep = ~np.isin(owner, list(self.hidden))
            points, owner = points[keep], owner[keep]
        palette = np.array([layer_colour(i) for i in range(int(owner.max(initial=0)) + 1)], np.uint8)
        # Every k-th point first, then the rest: the first n/k vertices are the thinned cloud drawn while the
        # camera moves (level of detail), without a second buffer.
        step = -(-points.shape[0] // self.moving_points) if self.moving_points > 0 else 1
        if step > 1:
            order = np.concatenate([np.arange(start, points.shape[0], step) for start in range(step)])
            points, owner = points[order], owner[order]
        self._thinned_count = -(-points.shape[0] // step)
        # One interleaved 16-byte vertex (x, y, z as floats, then r, g, b, pad): one fetch per point.
        vertices = np.zeros(points.shape[0], dtype=[("position", np.float32, 3), ("colour", np.uint8, 4)])
        vertices["position"] = points
        vertices["colour"][:, :3] = palette[owner]
        program.bind()
        self._vao.bind()
        self._vertices.bind()
        self._vertices.allocate(vertices.tobytes(), vertices.nbytes)
        program.enableAttributeArray(0)
        program.setAttributeBuffer(0, GL_FLOAT, 0, 3, 16)
        program.enableAttributeArray(1)
        program.setAttributeBuffer(1, GL_UNSIGNED_BYTE, 12, 3, 16)  # normalized to 0..1 by Qt
        self._vertices.release()
        self._vao.release()
        program.release()
        self._count = int(points.shape[0])
        self._uploaded = (id(self.scene), self.hidden)

    def _depth_range(self) -> tuple[float, float, float, float]:
        """Clip planes (near, far) around the scene, and the depth span the shading uses."""
        bounds = self.scene.bounds()
        position = self.camera.position()
        forward = self.camera.rotation()[2]
        if bounds is None:
            return 0.01, 100.0, 0.0, 1.0
        low, high = bounds
        corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
        depth = (corners - position) @ forward
        radius = float(np.linalg.norm(high - low))
        near = max(float(depth.min()) - radius, self.camera.distance * 1e-3, NEAR)
        far = max(float(depth.max()) + 4 * radius, near * 10)
        return near, far, float(depth.min()), float(depth.max())

    def paintGL(self) -> None:  # noqa: N802 - Qt override
        started = time.perf_counter()
        functions: QOpenGLFunctions = self.context().functions()
        r, g, b = (c / 255.0 for c in BACKGROUND)
        functions.glClearColor(r, g, b, 1.0)
        functions.glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT)
        program = self._program
        if program is not None and self.scene.points.shape[0]:
            if self._uploaded != (id(self.scene), self.hidden):
                self._upload()
            self._draw_points(functions, program)
        painter = QPainter(self)
        self.draw_overlays(painter)
        painter.end()
        self._count_frame(started)

    def _draw_points(self, functions: QOpenGLFunctions, program: QOpenGLShaderProgram) -> None:
        assert self._vao is not None
        ratio = self.devicePixelRatioF()
        near, far, shade_near, shade_far = self._depth_range()
        rotation = self.camera.rotation()
        view = np.eye(4)
        view[:3, :3] = rotation
        view[:3, 3] = -rotation @ self.camera.position()
        mvp = projection_matrix(self.camera.fov_y, self._aspect(), near, far) @ view
        functions.glViewport(0, 0, round(self.width() * ratio), round(self.height() * ratio))
        functions.glEnable(GL_DEPTH_TEST)
        thinned = self.moving and 0 < self._thinned_count < self._count
        # Thinned while moving: each point drawn wider (every k-th point, k times the area) so the cloud keeps
        # its surface rather than turning into dust.
        size = self.point_size * (round(math.sqrt(self._count / self._thinned_count)) if thinned else 1)
        if size > 1:  # wide points cost Mesa a slower path: size 1 leaves it off
            functions.glEnable(GL_PROGRAM_POINT_SIZE)
        else:
            functions.glDisable(GL_PROGRAM_POINT_SIZE)
        program.bind()
        program.setUniformValue(program.uniformLocation("mvp"), QMatrix4x4(*mvp.astype(np.float32).ravel()))
        eye, forward = self.camera.position(), rotation[2]
        program.setUniformValue(program.uniformLocation("eye"), *(float(v) for v in eye))
        program.setUniformValue(program.uniformLocation("forward"), *(float(v) for v in forward))
        program.setUniformValue1f(program.uniformLocation("near_depth"), shade_near)
        program.setUniformValue1f(program.uniformLocation("depth_scale"), 1.0 / max(shade_far - shade_near, 1e-6))
        program.setUniformValue1f(program.uniformLocation("point_size"), float(size * ratio))
        self._vao.bind()
        if thinned:
            self.thinned_frames += 1
        else:
            self.whole_frames += 1
        functions.glDrawArrays(GL_POINTS, 0, self._thinned_count if thinned else self._count)
        self._vao.release()
        program.release()
        functions.glDisable(GL_DEPTH_TEST)
