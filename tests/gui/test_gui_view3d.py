"""The 3D view's navigation and aids: zoom toward the cursor in small steps, pan one to one, orbit around the
detections, fit to detections and to the cloud, ground grid and axes, a measured frame rate and a busy
indicator; and the OpenGL view (under Xvfb with Mesa) drawing what the software renderer draws."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QPointF, Qt
from PySide6.QtGui import QWheelEvent
from PySide6.QtWidgets import QApplication

from objrec_apps.gui import CloudView, View3D
from objrec_apps.gui.cloud_render import CloudScene, OrbitCamera, ground_grid, nice_step, pick, pixel_point
from objrec_apps.gui.cloud_view import ZOOM_STEP, outlines_bounds
from objrec_apps.gui.gl_cloud_view import gl_available, make_cloud_view
from objrec_core import Frame, Stage, StageResults, get_kind
from tests.qt_waits import HANG_GUARD_MS

objrec3d_messages = pytest.importorskip("objrec3d.messages")
objrec3d_cloud = pytest.importorskip("objrec3d.cloud")

ROOT = Path(__file__).resolve().parents[2]


def wall_with_bump(width: int = 640, height: int = 480) -> np.ndarray:
    """A depth camera's view of a wall at 2 m with a box-shaped bump at 1.5 m in the middle: 307,200 points."""
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    z = np.full((height, width), 2.0, np.float32)
    z[(abs(u - width / 2) < 60) & (abs(v - height / 2) < 60)] = 1.5
    x, y = (u - width / 2) / 525.0 * z, (v - height / 2) / 525.0 * z
    return np.stack([x, y, z], axis=-1).reshape(-1, 3)


def box_outlines(centre=(0.0, 0.0, 1.5), size=0.2) -> list:
    m = objrec3d_messages
    pose = m.Pose(m.Point(*centre), m.Quaternion(0.0, 0.0, 0.0, 1.0))
    obj = m.DetectedObject3D("thing", m.OrientedBox(pose, size, size, size))
    return get_kind("3d").outlines(m.DetectedObject3DArray(objects=[obj]))


@pytest.fixture
def view(qtbot) -> CloudView:
    widget = CloudView()
    qtbot.addWidget(widget)
    widget.resize(800, 600)
    widget.show()
    qtbot.waitExposed(widget)
    widget.set_scene(CloudScene.from_layers([("original", wall_with_bump())]))
    return widget


def pixel_of(view: CloudView, point: np.ndarray) -> np.ndarray:
    uv, depth = view.project(np.asarray(point, dtype=np.float64)[None, :])
    assert depth[0] > 0
    return uv[0]


def wheel(view: CloudView, position: QPointF, notches: float) -> None:
    event = QWheelEvent(position, view.mapToGlobal(position), QPoint(0, 0), QPoint(0, round(120 * notches)),
                        Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier, Qt.ScrollPhase.NoScrollPhase,
                        False)
    QApplication.sendEvent(view, event)


def test_one_wheel_notch_zooms_ten_percent_toward_the_point_under_the_cursor(view):
    cursor = QPointF(610.0, 170.0)  # off centre, on the wall
    near_cursor = pick(view.camera, view.scene.points, cursor.x(), cursor.y(), 800, 600)
    assert near_cursor is not None and near_cursor[2] == pytest.approx(2.0)
    depth = float(view.camera.rotation()[2] @ (near_cursor - view.camera.position()))
    under = pixel_point(view.camera, cursor.x(), cursor.y(), 800, 600, depth)  # on the wall, under the cursor
    assert under[2] == pytest.approx(2.0, abs=0.01)
    elsewhere = np.array([-0.5, 0.3, 2.0])
    before_elsewhere = pixel_of(view, elsewhere)
    distance = view.camera.distance
    wheel(view, cursor, 1)
    assert view.camera.distance == pytest.approx(distance * ZOOM_STEP) and ZOOM_STEP == 0.9
    # The point under the cursor stays under it; the rest spreads away from it (closer: bigger).
    assert np.allclose(pixel_of(view, under), (cursor.x(), cursor.y()), atol=0.5)
    after_elsewhere = pixel_of(view, elsewhere)
    spread = np.linalg.norm(after_elsewhere - (cursor.x(), cursor.y())) / np.linalg.norm(
        before_elsewhere - (cursor.x(), cursor.y()))
    assert spread == pytest.approx(1 / 0.9, rel=0.05)
    for _ in range(5):  # many small steps still keep it there, and zooming out undoes them
        wheel(view, cursor, 1)
    assert np.allclose(pixel_of(view, under), (cursor.x(), cursor.y()), atol=0.5)
    wheel(view, cursor, -6)
    assert view.camera.distance == pytest.approx(distance)


def test_a_pan_moves_the_grabbed_point_one_to_one_with_the_mouse(view, qtbot):
    start, end = QPoint(400, 300), QPoint(447, 268)  # start on the bump, nearer than the view's target
    grabbed = pixel_point(view.camera, start.x(), start.y(), 800, 600,
                          float(view.camera.rotation()[2] @ (np.array([0.0, 0.0, 1.5]) - view.camera.position())))
    assert grabbed[2] == pytest.approx(1.5)
    at_start = pixel_of(view, grabbed)
    qtbot.mousePress(view, Qt.MouseButton.RightButton, pos=start)
    qtbot.mouseMove(view, QPoint(420, 290))
    qtbot.mouseMove(view, end)
    qtbot.mouseRelease(view, Qt.MouseButton.RightButton, pos=end)
    assert np.allclose(pixel_of(view, grabbed) - at_start, (47, -32), atol=0.5)


def test_dragging_orbits_around_the_detections(view, qtbot):
    centre = np.array([0.3, -0.1, 1.6])
    view.set_scene(view.scene, box_outlines(tuple(centre)))
    on_screen = pixel_of(view, centre)
    yaw = view.camera.yaw
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(300, 300))
    qtbot.mouseMove(view, QPoint(360, 280))
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=QPoint(360, 280))
    assert view.camera.yaw != pytest.approx(yaw)
    assert np.allclose(pixel_of(view, centre), on_screen, atol=0.5)  # the detection stays put, all turns about it
    view.set_orbit_detections(False)  # around the view's target (0.3 m behind it) instead: the detection moves
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPoint(300, 300))
    qtbot.mouseMove(view, QPoint(360, 280))
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=QPoint(360, 280))
    assert np.linalg.norm(pixel_of(view, centre) - on_screen) > 8


def test_fit_to_detections_and_fit_to_cloud_frame_them_from_the_current_direction(view):
    outlines = box_outlines((0.4, 0.2, 1.5), size=0.1)
    view.set_scene(view.scene, outlines)
    view.camera.rotate(0.5, 0.3)
    yaw, pitch = view.camera.yaw, view.camera.pitch
    assert view.fit_to_detections()
    corners, _ = view.project(np.asarray(outlines[0].box))
    assert (corners >= 0).all() and (corners[:, 0] < 800).all() and (corners[:, 1] < 600).all()
    span = corners.max(axis=0) - corners.min(axis=0)
    assert span[1] > 0.3 * 600  # it fills the view, not a dot in it
    assert (view.camera.yaw, view.camera.pitch) == (yaw, pitch)
    low, high = outlines_bounds(outlines)
    assert np.allclose(view.camera.target, (low + high) / 2)
    view.fit_to_cloud()
    low, high = view.scene.bounds()
    box = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    uv, depth = view.project(box)
    assert (depth > 0).all() and (uv >= 0).all() and (uv[:, 0] <= 800).all() and (uv[:, 1] <= 600).all()
    assert (view.camera.yaw, view.camera.pitch) == (yaw, pitch)
    view.set_scene(view.scene, [])
    assert not view.fit_to_detections()  # nothing to fit: the view stays


def test_the_ground_grid_lies_under_the_cloud_in_round_steps_and_is_drawn(view):
    segments, step = ground_grid(view.scene.bounds())
    assert step in (0.1, 0.2, 0.5) and nice_step(1.3) == 0.2 and nice_step(4.0) == 0.5
    assert np.allclose(segments[..., 1], view.scene.bounds()[1][1])  # at the lowest level (y points down)
    view.camera.rotate(0.0, -0.4)  # look down a little at the floor
    view.set_grid(False)
    without = view.grab().toImage()
    view.set_grid(True)
    with_grid = view.grab().toImage()
    changed = sum(without.pixel(x, y) != with_grid.pixel(x, y) for x in range(0, 800, 4) for y in range(300, 600, 4))
    assert changed > 100


class _StepClock:
    """A perf_counter that moves only when read (1 ms a read) or told: frame times the test chooses, whatever the
    machine's load."""

    def __init__(self) -> None:
        self.now = time.perf_counter() + 10.0  # past every real paint time, by more than the rate's window

    def perf_counter(self) -> float:
        self.now += 0.001
        return self.now


def test_the_frame_rate_label_counts_the_frames_really_drawn(view, monkeypatch):
    assert view.frames_per_second() == 0.0 or view.frames_drawn > 0
    clock = _StepClock()
    monkeypatch.setattr("objrec_apps.gui.cloud_view.time", clock)
    drawn = view.frames_drawn
    for _ in range(12):
        view.camera.rotate(0.05, 0.0)
        view.repaint()
        clock.now += 0.05  # 50 ms between frames, plus the clock's own reads while drawing
    assert view.frames_drawn - drawn >= 12
    assert view.frames_per_second(now=clock.now) == pytest.approx(1 / 0.052, rel=0.1)  # two reads a frame
    assert view.frame_ms == pytest.approx(1.0)  # a paint reads the clock at its start and at its end
    assert view.frames_per_second(now=clock.now + 2.0) == 0.0  # nothing drawn: 0, not the last figure


def test_the_3d_page_has_the_controls_and_a_busy_indicator_until_a_frame_comes(qtbot):
    page = View3D()
    qtbot.addWidget(page)
    page.resize(900, 700)
    page.show()
    assert not page.cloud_view.uses_opengl  # offscreen: the software renderer
    page.clear()
    assert page.is_busy and page.busy.isVisible() and "waiting" in page.cloud_view.busy_text
    image = page.cloud_view.grab().toImage()
    assert image.pixelColor(450, 280).lightness() > 0  # the banner is drawn, not a blank view
    cloud = objrec3d_cloud.PointCloud(wall_with_bump().reshape(480, 640, 3))
    results = StageResults(Frame(cloud), [Stage("input", "input", "input", cloud)],
                           objrec3d_messages.DetectedObject3DArray(objects=[]), 0.05)
    page.show_results(results, get_kind("3d"))
    assert not page.is_busy and not page.busy.isVisible()
    page.cloud_view.repaint()
    page.cloud_view.repaint()
    page.update_rate()
    assert page.fps_label.text().endswith("ms")
    page.fit_cloud.click()
    page.grid.setChecked(False)
    assert not page.cloud_view.show_grid


def test_the_window_says_it_is_busy_while_a_3d_source_opens(make_gui, qtbot):
    from objrec_apps.define import starting_system

    gui = make_gui(starting_system("shape"), source="demo:frames=0", fps_limit=10.0, wait=False)
    gui.open_source("demo")
    assert gui.view3d.is_busy
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        pass
    qtbot.waitUntil(lambda: not gui.view3d.is_busy, timeout=HANG_GUARD_MS)


def test_offscreen_has_no_opengl_so_the_software_view_is_used():
    assert not gl_available()
    assert isinstance(make_cloud_view(), CloudView)


GL_SCRIPT = textwrap.dedent("""
    import json, sys
    import numpy as np
    from PySide6.QtWidgets import QApplication
    app = QApplication(sys.argv[:1])
    sys.path.insert(0, sys.argv[1])
    from test_gui_view3d import wall_with_bump
    from objrec_apps.gui.cloud_render import BACKGROUND, CloudScene, render
    from objrec_apps.gui.gl_cloud_view import GLCloudView, gl_available
    points = wall_with_bump()
    near = points.copy()
    near[points[:, 2] > 1.8] = np.nan
    scene = CloudScene.from_layers([("original", points), ("near", near)])
    view = GLCloudView()
    view.resize(800, 600)
    view.show()
    view.set_scene(scene)
    view.set_grid(False)
    view.camera.rotate(0.3, 0.2)
    for _ in range(30):
        app.processEvents()
    image = view.grabFramebuffer().convertToFormat(view.grabFramebuffer().Format.Format_RGB888)
    gl = np.array(image.constBits(), np.uint8).reshape(600, image.bytesPerLine())[:, :2400].reshape(600, 800, 3)
    soft = render(scene, view.camera, 800, 600)
    region = (slice(60, 600), slice(0, 800))  # below the legend
    gl_fg = np.abs(gl[region].astype(int) - BACKGROUND).sum(axis=-1) > 12
    soft_fg = np.abs(soft[region].astype(int) - BACKGROUND).sum(axis=-1) > 12
    orange = (gl[region][..., 0].astype(int) - gl[region][..., 2] > 60) & gl_fg
    soft_orange = (soft[region][..., 0].astype(int) - soft[region][..., 2] > 60) & soft_fg
    print(json.dumps({"available": gl_available(), "failed": view.gl_failed,
                      "agree": float((gl_fg == soft_fg).mean()), "fg": float(gl_fg.mean()),
                      "orange_agree": float((orange == soft_orange).mean()), "orange": float(orange.mean())}))
""")


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="needs xvfb-run (Xvfb) and Mesa")
def test_the_opengl_view_draws_what_the_software_renderer_draws_under_xvfb(tmp_path):
    script = tmp_path / "gl_view.py"
    script.write_text(GL_SCRIPT)
    # the repository on the path: the script imports this test module, which imports tests.qt_waits
    env = {**os.environ, "QT_QPA_PLATFORM": "xcb", "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
    done = subprocess.run(["xvfb-run", "-a", sys.executable, str(script), str(Path(__file__).parent)],
                          capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    assert figures["available"] and figures["failed"] == ""
    assert figures["fg"] > 0.3 and figures["orange"] > 0.01  # the cloud and the near layer (the bump) are drawn
    print(figures)
    assert figures["agree"] > 0.97 and figures["orange_agree"] > 0.97  # where the software renderer draws them


def test_the_camera_helpers_keep_their_promises():
    camera = OrbitCamera()
    camera.fit((np.array([-1.0, -1.0, 1.0]), np.array([1.0, 1.0, 3.0])), 4 / 3)
    assert camera.distance > 0
