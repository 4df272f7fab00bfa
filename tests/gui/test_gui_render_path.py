"""The 3D view picks the faster renderer for the machine (the OpenGL renderer's name:
a software rasteriser such as Mesa's llvmpipe -> the NumPy renderer, a graphics card -> OpenGL), the
choice can be overridden (OBJREC_RENDERER), and a large cloud is thinned while the camera moves and drawn
whole once it stops. Frame rates are the benchmark's (benchmarks/bench_gui.py); these tests count frames."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("PySide6", reason="the GUI extra (PySide6) is not installed")

from PySide6.QtCore import QEvent, QPoint, QPointF, Qt
from PySide6.QtGui import QMouseEvent, QWheelEvent

from objrec_apps.gui.cloud_render import CloudScene
from objrec_apps.gui.cloud_view import MOVING_POINTS, CloudView
from objrec_apps.gui.gl_cloud_view import make_cloud_view
from objrec_apps.gui.render_path import choose_render_path, is_software_gl, requested

ROOT = Path(__file__).resolve().parents[2]
LLVMPIPE = "llvmpipe (LLVM 15.0.6, 256 bits) (Mesa/X.org)"
GPU = "NVIDIA GeForce GTX 1650/PCIe/SSE2 (NVIDIA Corporation)"


def organized_scene() -> CloudScene:
    """A 640x480 organized cloud (307,200 points, a wall) and a filter layer over part of it."""
    v, u = np.mgrid[0:480, 0:640].astype(np.float32)
    z = 1.0 + 0.5 * (v / 480)
    points = np.stack([(u - 320) / 525 * z, (v - 240) / 525 * z, z], axis=-1).reshape(-1, 3)
    near = points.copy()
    near[points[:, 2] > 1.3] = np.nan
    return CloudScene.from_layers([("original", points), ("near", near)])


@pytest.mark.parametrize(("renderer", "software"), [
    (LLVMPIPE, True),
    ("softpipe", True),
    ("Mesa X11 swrast", True),
    ("Google SwiftShader", True),
    ("Microsoft Basic Render Driver", True),
    ("Mesa Intel(R) UHD Graphics 620 (KBL GT2) (Intel)", False),
    (GPU, False),
    ("AMD Radeon RX 6600 (radeonsi, navi23, LLVM 15.0.7, DRM 3.49) (AMD)", False),
])
def test_software_opengl_is_told_from_a_graphics_card_by_the_renderer_name(renderer, software):
    assert is_software_gl(renderer) is software
    path = choose_render_path("auto", renderer)
    assert path.opengl is not software
    assert renderer in path.reason


def test_the_choice_can_be_overridden(monkeypatch):
    assert choose_render_path("opengl", LLVMPIPE).opengl  # asked for: OpenGL even drawn by the processor
    assert not choose_render_path("software", GPU).opengl
    assert not choose_render_path("opengl", None).opengl  # no OpenGL at all: the software view still works
    monkeypatch.delenv("OBJREC_GL", raising=False)
    for value, meant in [("software", "software"), ("gl", "opengl"), ("OpenGL", "opengl"), ("", "auto"),
                         ("auto", "auto")]:
        monkeypatch.setenv("OBJREC_RENDERER", value)
        assert requested() == meant
        assert choose_render_path(None, GPU).opengl is (meant != "software")
    monkeypatch.setenv("OBJREC_RENDERER", "fast")
    assert requested() == "auto"  # an unknown value is logged and read as auto
    monkeypatch.setenv("OBJREC_RENDERER", "opengl")
    monkeypatch.setenv("OBJREC_GL", "0")  # the older switch still turns OpenGL off
    assert requested() == "software"


def test_offscreen_chooses_the_software_view_and_says_why(qtbot):
    view = make_cloud_view()
    qtbot.addWidget(view)
    assert isinstance(view, CloudView)
    assert not view.render_path.opengl and "offscreen" in view.render_path.reason


def _mouse(kind: QEvent.Type, x: float, y: float, buttons: Qt.MouseButton) -> QMouseEvent:
    button = Qt.MouseButton.LeftButton if kind != QEvent.Type.MouseMove else Qt.MouseButton.NoButton
    return QMouseEvent(kind, QPointF(x, y), QPointF(x, y), button, buttons, Qt.KeyboardModifier.NoModifier)


def test_a_large_cloud_is_thinned_while_it_turns_and_drawn_whole_when_it_stops(qtbot):
    view = CloudView()
    qtbot.addWidget(view)
    view.resize(800, 600)
    view.show()
    scene = organized_scene()
    view.set_scene(scene)
    qtbot.waitUntil(lambda: view.whole_frames == 1, timeout=HANG_GUARD_MS)  # the first paint, once mapped
    assert view.thinned_frames == 0
    thin = scene.thinned(MOVING_POINTS)
    assert scene.points.shape[0] == 307_200 and thin.points.shape[0] == 76_800  # every 4th point
    assert np.array_equal(thin.points, scene.points[::4]) and np.array_equal(thin.owner, scene.owner[::4])
    assert thin.counts == scene.counts and thin.names == scene.names  # the legend keeps the real counts
    assert scene.thinned(MOVING_POINTS) is thin  # made once per scene
    yaw = view.camera.yaw
    view.mousePressEvent(_mouse(QEvent.Type.MouseButtonPress, 400, 300, Qt.MouseButton.LeftButton))
    for step in range(1, 6):
        view.mouseMoveEvent(_mouse(QEvent.Type.MouseMove, 400 + 10 * step, 300, Qt.MouseButton.LeftButton))
        view.repaint()
    assert view.camera.yaw != yaw and view.moving
    assert view.thinned_frames == 5 and view.whole_frames == 1  # every drawn step of the drag was thinned
    assert view.render_image().qimage.width() == 400  # and drawn at half the resolution, scaled up
    view.mouseReleaseEvent(_mouse(QEvent.Type.MouseButtonRelease, 450, 300, Qt.MouseButton.NoButton))
    assert not view.moving
    view.repaint()
    assert view.whole_frames == 2  # released: the whole cloud again
    assert view.render_image().qimage.width() == 800
    # the wheel: thinned while it turns, whole once it has been still for a moment (a timer, not a release)
    wheel = QWheelEvent(QPointF(400, 300), QPointF(400, 300), QPoint(), QPoint(0, 120), Qt.MouseButton.NoButton,
                        Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase, False)
    view.wheelEvent(wheel)
    view.repaint()
    assert view.thinned_frames == 6
    qtbot.waitUntil(lambda: not view.moving, timeout=HANG_GUARD_MS)
    view.repaint()
    assert view.whole_frames == 3


def test_a_small_cloud_is_always_drawn_whole(qtbot):
    view = CloudView()
    qtbot.addWidget(view)
    view.resize(400, 300)
    view.show()
    points = np.random.default_rng(1).normal(size=(5000, 3)).astype(np.float32) + np.float32([0, 0, 4])
    view.set_scene(CloudScene.from_layers([("original", points)]))
    qtbot.waitUntil(lambda: view.whole_frames == 1, timeout=HANG_GUARD_MS)
    view.start_moving()
    view.camera.rotate(0.1, 0.0)
    view.repaint()
    assert view.thinned_frames == 0 and view.whole_frames == 2


CHOICE_SCRIPT = textwrap.dedent("""
    import json, sys
    from PySide6.QtWidgets import QApplication
    app = QApplication(sys.argv[:1])
    from objrec_apps.gui.gl_cloud_view import GLCloudView, make_cloud_view
    view = make_cloud_view()
    print(json.dumps({"gl": isinstance(view, GLCloudView), "renderer": view.render_path.renderer,
                      "reason": view.render_path.reason}))
""")


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="needs xvfb-run (Xvfb) and Mesa")
@pytest.mark.parametrize("setting", ["auto", "opengl", "software"])
def test_under_xvfb_mesa_the_software_view_is_chosen_unless_opengl_is_asked_for(tmp_path, setting):
    script = tmp_path / "choice.py"
    script.write_text(CHOICE_SCRIPT)
    env = {**os.environ, "QT_QPA_PLATFORM": "xcb", "OBJREC_RENDERER": setting}
    env.pop("OBJREC_GL", None)
    done = subprocess.run(["xvfb-run", "-a", sys.executable, str(script)], capture_output=True, text=True,
                          timeout=120, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    choice = json.loads(done.stdout.strip().splitlines()[-1])
    print(choice)
    if setting == "software":
        assert not choice["gl"]
        return
    assert is_software_gl(choice["renderer"]), choice  # Xvfb has no graphics card: Mesa draws on the processor
    assert choice["gl"] is (setting == "opengl"), choice


GL_LOD_SCRIPT = textwrap.dedent("""
    import json, sys
    import numpy as np
    from PySide6.QtWidgets import QApplication
    app = QApplication(sys.argv[:1])
    sys.path.insert(0, sys.argv[1])
    from test_gui_render_path import organized_scene
    from objrec_apps.gui.cloud_render import BACKGROUND
    from objrec_apps.gui.gl_cloud_view import GLCloudView

    def settle():
        for _ in range(30):
            app.processEvents()

    def foreground():
        image = view.grabFramebuffer().convertToFormat(view.grabFramebuffer().Format.Format_RGB888)
        rgb = np.array(image.constBits(), np.uint8).reshape(600, image.bytesPerLine())[:, :2400].reshape(600, 800, 3)
        return float((np.abs(rgb[80:].astype(int) - BACKGROUND).sum(axis=-1) > 12).mean())

    view = GLCloudView()
    view.resize(800, 600)
    view.show()
    view.set_scene(organized_scene())
    view.set_grid(False)
    settle()
    whole = (view.whole_frames, view.thinned_frames, foreground())
    view.start_moving()
    view.camera.rotate(0.05, 0.0)
    view.update()
    settle()
    moving = (view.whole_frames, view.thinned_frames, foreground())
    view.stop_moving()
    settle()
    print(json.dumps({"whole": whole, "moving": moving, "after": [view.whole_frames, view.thinned_frames],
                      "count": view._count, "thinned_count": view._thinned_count}))
""")


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="needs xvfb-run (Xvfb) and Mesa")
def test_the_opengl_view_draws_a_quarter_of_the_points_while_moving(tmp_path):
    script = tmp_path / "gl_lod.py"
    script.write_text(GL_LOD_SCRIPT)
    env = {**os.environ, "QT_QPA_PLATFORM": "xcb", "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
    done = subprocess.run(["xvfb-run", "-a", sys.executable, str(script), str(Path(__file__).parent)],
                          capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    print(figures)
    assert figures["count"] == 307_200 and figures["thinned_count"] == 76_800  # every 4th point first
    whole, moving = figures["whole"], figures["moving"]
    assert whole[0] >= 1 and whole[1] == 0
    assert moving[1] >= 1  # drawn thinned while moving
    assert figures["after"][0] > moving[0]  # and whole again once it stopped
    assert moving[2] > 0.5 * whole[2]  # the thinned cloud still covers the view where the whole one does
