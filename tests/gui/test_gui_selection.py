"""InteractiveImage (image coordinates, rubber band, areaSelected) and selecting a feature target with the
mouse in the running window, which the FeatureDetector then finds in the following frames."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QEvent, QPointF, Qt
from PySide6.QtGui import QMouseEvent
from PySide6.QtWidgets import QApplication

from objrec_apps.define import starting_system
from objrec_apps.gui import InteractiveImage
from objrec_core import Rect
from tests.qt_waits import HANG_GUARD_MS


def mouse(widget, kind: QEvent.Type, pos: QPointF, buttons: Qt.MouseButton, button: Qt.MouseButton) -> None:
    global_pos = QPointF(widget.mapToGlobal(pos.toPoint()))
    event = QMouseEvent(kind, pos, global_pos, button, buttons, Qt.KeyboardModifier.NoModifier)
    QApplication.sendEvent(widget, event)


def drag(widget, start: QPointF, end: QPointF, steps: int = 5, during=None) -> None:
    """Press, move in steps, release: the events a real drag delivers."""
    left, none = Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton
    mouse(widget, QEvent.Type.MouseButtonPress, start, left, left)
    for i in range(1, steps + 1):
        point = start + (end - start) * (i / steps)
        mouse(widget, QEvent.Type.MouseMove, point, left, none)
    if during is not None:
        during()
    mouse(widget, QEvent.Type.MouseButtonRelease, end, none, left)


def image_view(qtbot, image: np.ndarray, width: int, height: int) -> InteractiveImage:
    view = InteractiveImage()
    qtbot.addWidget(view)
    view.resize(width, height)
    view.set_image(image)
    view.show()
    qtbot.waitExposed(view)
    return view


def test_the_image_is_scaled_with_its_aspect_ratio_kept(qtbot):
    view = image_view(qtbot, np.zeros((100, 200, 3), np.uint8), 800, 600)
    area = view.image_rect()
    assert (area.width(), area.height()) == (800, 400)  # scale 4, letterboxed top and bottom
    assert (area.left(), area.top()) == (0, 100)
    point = view.to_image(QPointF(400, 300))
    assert (point.x(), point.y()) == (100, 50)


def test_mouse_events_are_reported_in_image_coordinates(qtbot):
    view = image_view(qtbot, np.zeros((100, 200, 3), np.uint8), 800, 600)
    pressed, moved, released = [], [], []
    view.mousePressed.connect(lambda p: pressed.append((p.x(), p.y())))
    view.mouseMoved.connect(lambda p: moved.append((p.x(), p.y())))
    view.mouseReleased.connect(lambda p: released.append((p.x(), p.y())))
    drag(view, QPointF(40, 140), QPointF(440, 300), steps=2)
    assert pressed == [(10, 10)]
    assert moved == [(60, 30), (110, 50)]
    assert released == [(110, 50)]


def test_a_drag_selects_a_rectangle_and_draws_a_rubber_band(qtbot):
    image = np.full((120, 160, 3), 40, np.uint8)
    view = image_view(qtbot, image, 640, 480)  # scale 4, no letterbox
    selected: list[Rect] = []
    view.areaSelected.connect(selected.append)
    band_pixels: list[tuple[int, int, int]] = []

    def look() -> None:
        picture = view.grab().toImage()
        band_pixels.append(picture.pixelColor(200, 200).getRgb()[:3])  # inside the band
        band_pixels.append(picture.pixelColor(600, 440).getRgb()[:3])  # outside it
        assert view.selection() == Rect(10, 20, 90, 70)

    drag(view, QPointF(40, 80), QPointF(400, 360), during=look)
    assert selected == [Rect(10, 20, 90, 70)]
    inside, outside = band_pixels
    assert outside == (40, 40, 40)
    assert inside != outside and inside[2] > inside[0]  # the band's translucent blue over the grey
    assert view.selection() is None  # released: no band any more


def test_a_drag_backwards_and_off_the_image_is_clipped_and_a_click_selects_nothing(qtbot):
    view = image_view(qtbot, np.zeros((120, 160), np.uint8), 640, 480)
    selected: list[Rect] = []
    view.areaSelected.connect(selected.append)
    drag(view, QPointF(400, 360), QPointF(700, 520))  # towards the lower right, past the edge
    drag(view, QPointF(400, 360), QPointF(40, 80))  # backwards
    drag(view, QPointF(100, 100), QPointF(104, 101))  # a click, not a selection
    assert selected == [Rect(100, 90, 60, 30), Rect(10, 20, 90, 70)]


def test_images_that_arrive_during_a_drag_wait_for_the_release(qtbot):
    first = np.zeros((120, 160), np.uint8)
    view = image_view(qtbot, first, 640, 480)
    tags = []
    view.areaSelected.connect(lambda rect: tags.append(view.tag))
    view.set_image(first, tag="first")
    drag(view, QPointF(40, 80), QPointF(400, 360), during=lambda: view.set_image(first + 1, tag="second"))
    assert tags == ["first"] and view.tag == "second" and int(view.image()[0, 0]) == 1


def test_hovering_shows_coordinates_bgr_and_hsv(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    view = gui.stage_views.view("input")
    frame = gui.last_results.frame.data
    target = QPointF(72.5, 120.5)  # the centre of the demo's red disk in frame 0
    mouse(view, QEvent.Type.MouseMove, view.to_widget(target), Qt.MouseButton.NoButton, Qt.MouseButton.NoButton)
    b, g, r = (int(c) for c in frame[120, 72])
    text = gui.hover_label.text()
    assert text.startswith("x 72, y 120") and f"BGR ({b}, {g}, {r})" in text
    assert "HSV (" in text and r > 150 > g  # red
    mask_view = gui.stage_views.view("colour")
    mouse(mask_view, QEvent.Type.MouseMove, mask_view.to_widget(target), Qt.MouseButton.NoButton,
          Qt.MouseButton.NoButton)
    assert "colour: value 255" in gui.hover_label.text()


def test_a_mouse_selection_becomes_the_target_found_in_the_next_frames(make_gui, qtbot):
    pytest.importorskip("objrec2d.feature_detector")
    system = starting_system("feature")
    detector = system.module("poster")
    detector.clear_target()  # the shipped file holds a target: start without one
    gui = make_gui(system, paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()  # frame 0, where the demo's poster faces the camera
    results = gui.last_results
    assert results.frame.index == 0 and len(results.objects) == 0
    view = gui.stage_views.view("input")
    from objrec2d import DemoScene

    x, y, w, h = DemoScene().target.reference_rect  # the poster, head-on in frame 0
    drag(view, view.to_widget(QPointF(x, y)), view.to_widget(QPointF(x + w, y + h)))
    qtbot.waitUntil(lambda: detector.target is not None, timeout=HANG_GUARD_MS)
    assert detector.target.rect == Rect(x, y, w, h)
    qtbot.waitUntil(lambda: "taken by poster" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)

    found = []

    def record(shown) -> None:
        truth = shown.results.frame.truth["target"]["corners"]
        objects = shown.results.objects.objects
        found.append((shown.results.frame.index, objects, np.array(truth)))

    gui.frameShown.connect(record)
    gui.set_paused(False)
    qtbot.waitUntil(lambda: len({f[0] for f in found if f[0] > 0}) >= 10, timeout=HANG_GUARD_MS)
    gui.set_paused(True)
    later = [f for f in found if f[0] > 0]
    hits = 0
    for _, objects, truth in later:
        if objects:
            corners = np.array(objects[0].polygon.xy())
            assert np.abs(corners - truth).max() < 4.0, "the found outline must lie on the poster"
            hits += 1
    assert hits >= 0.9 * len(later)


def test_a_refused_selection_shows_the_reason(make_gui, qtbot):
    pytest.importorskip("objrec2d.feature_detector")
    system = starting_system("feature")
    system.module("poster").clear_target()
    gui = make_gui(system, paused=True, wait=False)
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.worker.step()
    view = gui.stage_views.view("input")
    # A corner of the demo's plain, noisy background: nothing to match.
    drag(view, view.to_widget(QPointF(150, 5)), view.to_widget(QPointF(165, 15)))
    qtbot.waitUntil(lambda: "refused" in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
    assert gui.system.module("poster").target is None
    assert "poster refused the selection:" in gui.statusBar().currentMessage()


def test_selections_reach_every_registered_callback(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    received = []
    gui.add_selection_callback(lambda rect, results: received.append((rect, results.frame.index)))
    view = gui.stage_views.view("input")
    start = view.to_widget(QPointF(10, 10))
    drag(view, start, view.to_widget(QPointF(50, 40)))
    assert received and received[0][0] == Rect(10, 10, 40, 30)
    # blobs ignores selections: the default callback says so rather than "taken by blobs"
    qtbot.waitUntil(lambda: "no detector in the pipeline takes selections (blobs ignores them)"
                    in gui.statusBar().currentMessage(), timeout=HANG_GUARD_MS)
