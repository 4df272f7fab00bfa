"""The 3D view, rendered offscreen by the NumPy point renderer: the cloud's pixels in their layer colours,
the boxes (the kind's outlines) and their coordinate frames, mouse interaction, the detection list, and a
3D pipeline live."""

from __future__ import annotations

import time

import numpy as np
import pytest
from PySide6.QtCore import QPointF, Qt

from objrec_apps.gui import CloudView, View3D
from objrec_apps.gui.cloud_render import BACKGROUND, CloudScene, OrbitCamera, layer_colour, render
from objrec_apps.gui.cloud_view import box_frame
from objrec_core import Frame, Stage, StageResults, get_kind
from tests.qt_waits import HANG_GUARD_MS

objrec3d_messages = pytest.importorskip("objrec3d.messages")
objrec3d_cloud = pytest.importorskip("objrec3d.cloud")
DetectedObject3D = objrec3d_messages.DetectedObject3D
OrientedBox, Pose, Point, Quaternion = (objrec3d_messages.OrientedBox, objrec3d_messages.Pose,
                                        objrec3d_messages.Point, objrec3d_messages.Quaternion)
PointCloud = objrec3d_cloud.PointCloud
DetectedObject3DArray = objrec3d_messages.DetectedObject3DArray


def organized_scene(width: int = 640, height: int = 480) -> PointCloud:
    """A depth camera's view of a wall at 2 m with a box-shaped bump in front: 307,200 points."""
    v, u = np.mgrid[0:height, 0:width].astype(np.float32)
    z = np.full((height, width), 2.0, np.float32)
    bump = (abs(u - width / 2) < 60) & (abs(v - height / 2) < 60)
    z[bump] = 1.5
    x, y = (u - width / 2) / 525.0 * z, (v - height / 2) / 525.0 * z
    points = np.stack([x, y, z], axis=-1)
    points[::7, ::5] = np.nan  # missing returns
    return PointCloud(points)


def filtered(cloud: PointCloud, keep: np.ndarray) -> PointCloud:
    points = cloud.points.copy()
    points[~keep] = np.nan
    return PointCloud(points, width=cloud.width, height=cloud.height)


def box_object(centre=(0.0, 0.0, 1.5), size=0.2) -> DetectedObject3D:
    pose = Pose(Point(*centre), Quaternion(0.0, 0.0, 0.0, 1.0))
    return DetectedObject3D("thing", OrientedBox(pose, size, size, size), shape="sphere", radius=size / 2,
                            inliers=1234)


def outlines(*objects: DetectedObject3D) -> list:
    """The objects' box outlines, as the 3d kind gives them to views."""
    return get_kind("3d").outlines(DetectedObject3DArray(objects=list(objects)))


def colour_pixels(image: np.ndarray, colour: tuple[int, int, int]) -> np.ndarray:
    """Pixels that are ``colour`` darkened by the depth shading (any factor 0.4..1)."""
    rgb = image[..., :3].astype(np.float32)
    reference = np.array(colour, np.float32)
    factor = rgb.sum(axis=-1) / reference.sum()
    expected = factor[..., None] * reference
    return (np.abs(rgb - expected).max(axis=-1) <= 3) & (factor > 0.4) & (factor <= 1.01)


def grab(view) -> np.ndarray:
    image = view.grab().toImage()
    image = image.convertToFormat(image.Format.Format_RGB888)
    return np.array(image.constBits(), dtype=np.uint8).reshape(image.height(), image.bytesPerLine())[
        :, : image.width() * 3].reshape(image.height(), image.width(), 3)


def test_layers_merge_into_one_point_set_with_owners():
    cloud = organized_scene()
    near = filtered(cloud, cloud.points[:, 2] < 1.8)
    scene = CloudScene.from_layers([("original", cloud.points), ("near", near.points)])
    valid = int(np.isfinite(cloud.points).all(axis=1).sum())
    assert scene.points.shape == (valid, 3)  # drawn once, recoloured, not twice
    assert scene.counts == [valid, int(np.isfinite(near.points).all(axis=1).sum())]
    assert np.bincount(scene.owner).tolist() == [scene.counts[0] - scene.counts[1], scene.counts[1]]


def test_the_renderer_draws_every_layer_in_its_colour_and_the_nearest_point_wins():
    cloud = organized_scene()
    near = filtered(cloud, cloud.points[:, 2] < 1.8)
    scene = CloudScene.from_layers([("original", cloud.points), ("near", near.points)])
    camera = OrbitCamera()
    camera.fit(scene.bounds(), 640 / 480)
    image = render(scene, camera, 640, 480, shade=False)
    grey, orange = layer_colour(0), layer_colour(1)
    is_grey = (image == grey).all(axis=-1)
    is_orange = (image == orange).all(axis=-1)
    # The bump's 120 x 120 points are seen from a little behind the sensor: fewer pixels than points.
    assert is_grey.sum() > 100_000 and 5_000 < is_orange.sum() < 120 * 120
    ys, xs = np.nonzero(is_orange)
    assert abs(xs.mean() - 320) < 15 and abs(ys.mean() - 240) < 15  # the bump, in the middle
    assert (image == BACKGROUND).all(axis=-1).sum() > 0  # missing returns and the margin stay background
    hidden = render(scene, camera, 640, 480, shade=False, hidden=frozenset({1}))
    assert not (hidden == orange).all(axis=-1).any()


def test_a_307200_point_cloud_renders_fast_enough_to_turn_smoothly():
    scene = CloudScene.from_layers([("original", organized_scene().points)])
    camera = OrbitCamera()
    camera.fit(scene.bounds())
    times = []
    for yaw in np.linspace(0, 0.5, 5):
        camera.yaw = yaw
        start = time.thread_time()  # CPU time of this thread: a loaded machine cannot fail it
        render(scene, camera, 800, 600)
        times.append(time.thread_time() - start)
    assert min(times) < 0.1, f"fastest of 5 renders took {min(times) * 1000:.0f} ms of CPU"


def test_the_cloud_view_shows_the_cloud_and_the_boxes_offscreen(qtbot):
    view = CloudView()
    qtbot.addWidget(view)
    view.resize(640, 480)
    view.show()
    qtbot.waitExposed(view)
    cloud = organized_scene()
    near = filtered(cloud, cloud.points[:, 2] < 1.8)
    view.set_scene(CloudScene.from_layers([("original", cloud.points), ("near", near.points)]), outlines(box_object()))
    picture = grab(view)
    assert colour_pixels(picture, layer_colour(0)).sum() > 50_000
    assert colour_pixels(picture, layer_colour(1)).sum() > 5_000
    yellow = (picture == (255, 255, 0)).all(axis=-1)
    ys, xs = np.nonzero(yellow)
    assert yellow.sum() > 150  # the box's edges
    assert abs(np.median(xs) - 320) < 40 and abs(np.median(ys) - 240) < 40
    view.camera.rotate(0.5, 0.4)  # from the sensor's view the z axis points straight away: turn a little
    view.update()
    turned = grab(view)
    for colour in ((255, 60, 60), (60, 255, 60), (80, 140, 255)):  # the frame's x, y, z axes
        assert (turned == colour).all(axis=-1).sum() > 5, f"axis colour {colour} missing"


def test_the_mouse_rotates_pans_zooms_and_double_click_resets(qtbot):
    view = CloudView()
    qtbot.addWidget(view)
    view.resize(400, 300)
    view.show()
    view.set_scene(CloudScene.from_layers([("original", organized_scene().points)]))
    fitted = (view.camera.yaw, view.camera.pitch, view.camera.distance, view.camera.target.copy())
    before = grab(view)
    qtbot.mousePress(view, Qt.MouseButton.LeftButton, pos=QPointF(200, 150).toPoint())
    qtbot.mouseMove(view, QPointF(260, 130).toPoint())
    qtbot.mouseRelease(view, Qt.MouseButton.LeftButton, pos=QPointF(260, 130).toPoint())
    assert view.camera.yaw != fitted[0] and view.camera.pitch != fitted[1]
    assert not np.array_equal(grab(view), before)
    target = view.camera.target.copy()
    qtbot.mousePress(view, Qt.MouseButton.RightButton, pos=QPointF(200, 150).toPoint())
    qtbot.mouseMove(view, QPointF(220, 150).toPoint())
    qtbot.mouseRelease(view, Qt.MouseButton.RightButton, pos=QPointF(220, 150).toPoint())
    assert not np.allclose(view.camera.target, target)
    distance = view.camera.distance
    view.camera.zoom(0.5)
    assert view.camera.distance == pytest.approx(distance / 2)
    qtbot.mouseDClick(view, Qt.MouseButton.LeftButton, pos=QPointF(100, 100).toPoint())
    assert (view.camera.yaw, view.camera.pitch, view.camera.distance) == pytest.approx(fitted[:3])
    assert np.allclose(view.camera.target, fitted[3])


def test_the_3d_page_lists_the_detections(qtbot):
    page = View3D()
    qtbot.addWidget(page)
    cloud = organized_scene()
    near = filtered(cloud, cloud.points[:, 2] < 1.8)
    stages = [Stage("input", "input", "input", cloud), Stage("near", "DistanceFilter", "filter", near)]
    objects = [box_object((0.1, -0.2, 1.5), 0.08)]
    page.show_results(StageResults(Frame(cloud), stages, DetectedObject3DArray(objects=objects), 0.05), get_kind("3d"))
    cells = [page.table.item(0, c).text() for c in range(page.table.columnCount())]
    assert cells == ["1", "thing", "sphere", "0.0400", "+0.100", "-0.200", "+1.500", "0.080 × 0.080 × 0.080", "1234"]
    assert [c.text() for c in page._layer_checks] == ["original", "near"]
    page._layer_checks[1].setChecked(False)
    assert page.cloud_view.hidden == frozenset({1})


def test_a_box_outline_gives_centre_axes_and_sides():
    pose = Pose(Point(0.5, -0.25, 2.0), Quaternion(0.0, 0.0, np.sin(np.pi / 8), np.cos(np.pi / 8)))  # 45° about z
    obj = DetectedObject3D("crate", OrientedBox(pose, 0.4, 0.2, 0.1))
    (outline,) = outlines(obj)
    centre, axes, sides = box_frame(outline.box)
    assert centre == pytest.approx([0.5, -0.25, 2.0])
    assert sides == pytest.approx([0.4, 0.2, 0.1])
    half = np.sqrt(0.5)
    assert axes == pytest.approx(np.array([[half, half, 0.0], [-half, half, 0.0], [0.0, 0.0, 1.0]]))
    assert box_frame(np.full((8, 3), np.nan)) is None


@pytest.mark.slow
def test_the_shape_system_runs_live_in_the_window(make_gui, qtbot):
    from objrec_apps.define import starting_system
    from objrec_core import open_source

    source = open_source("demo", "3d")
    gui = make_gui(starting_system("shape"), source=source, wait=False, paused=True)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS) as signal:
        gui.worker.step()
    results = signal.args[0].results
    assert gui.central.currentWidget() is gui.view3d
    assert [name for name in gui.view3d.cloud_view.scene.names] == ["original", "DistanceFilter", "PlaneRemovalFilter"]
    cylinders = [o for o in results.objects.objects if o.shape == "cylinder"]
    assert cylinders and gui.view3d.table.rowCount() == len(results.objects.objects)
    assert gui.view3d.table.item(0, 2).text() == "cylinder"
    picture = grab(gui.view3d.cloud_view)
    assert (picture == (255, 255, 0)).all(axis=-1).sum() > 20
