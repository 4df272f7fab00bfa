"""On a large image (55 MP) the detections stay visible when the view scales it down."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from PySide6.QtGui import QImage

from objrec_apps.define import starting_system
from objrec_apps.gui.images import display_buffer, display_keeping_drawing
from objrec_core import Frame, FrameSource
from tests.qt_waits import HANG_GUARD_MS

objrec2d = pytest.importorskip("objrec2d")

WIDTH, HEIGHT = 9000, 6112  # 55.0 million pixels
CENTRE, RADIUS = (4500, 3056), 600  # the shipped blob detector keeps outlines up to 5000 px long
GREY, RED = (128, 128, 128), (40, 35, 215)


def big_photo() -> np.ndarray:
    """A big blank picture with one red disk."""
    image = np.full((HEIGHT, WIDTH, 3), GREY, np.uint8)
    cv2.circle(image, CENTRE, RADIUS, RED, -1)
    return image


class OnePhoto(FrameSource):
    name = "big photo"

    def __init__(self, image: np.ndarray) -> None:
        self.image = image

    @property
    def length(self) -> int:
        return 1

    def __iter__(self):
        yield Frame(self.image, 0.0, 0, self.name)


def outline_share(picture: np.ndarray, left: int, top: int, scale: float) -> float:
    """The share of 180 points round the disk's edge, in ``picture`` (a view of the photo scaled by ``scale``
    with its top-left corner at ``left``, ``top``), that have a drawn pixel (yellow: OpenCV's first palette
    colour, neither the grey background nor the red disk) within 2 pixels."""
    hits = 0
    for angle in np.linspace(0, 2 * np.pi, 180, endpoint=False):
        x = left + (CENTRE[0] + RADIUS * np.cos(angle)) * scale
        y = top + (CENTRE[1] + RADIUS * np.sin(angle)) * scale
        patch = picture[int(y) - 2:int(y) + 3, int(x) - 2:int(x) + 3, :3].astype(int)
        yellow = (patch[..., 0] < 60) & (patch[..., 1] > 200) & (patch[..., 2] > 200)
        hits += bool(yellow.any())
    return hits / 180


def test_a_drawing_survives_scaling_down_ten_times():
    photo = big_photo()
    from objrec2d.annotate import draw_objects
    from objrec2d.messages import DetectedObject2D, Polygon

    outline = Polygon.from_xy(cv2.ellipse2Poly(CENTRE, (RADIUS, RADIUS), 0, 0, 360, 5).tolist())
    drawn = draw_objects(photo, [DetectedObject2D("disk", outline)])  # what the 2D kind draws
    size = (800, round(HEIGHT * 800 / WIDTH))
    scale = 800 / WIDTH
    assert outline_share(display_buffer(drawn, size), 0, 0, scale) < 0.5  # the plain scaling loses it
    assert outline_share(display_keeping_drawing(drawn, photo, size), 0, 0, scale) >= 0.95


@pytest.mark.timeout(300)
def test_the_detections_on_a_55_megapixel_image_stay_visible_in_the_view(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), source=OnePhoto(big_photo()), wait=False)
    qtbot.waitUntil(lambda: gui.last_results is not None and len(gui.last_results.objects.objects) == 1,
                    timeout=HANG_GUARD_MS)
    view = gui.stage_views.view("input")
    # the first frame is drawn before the view's size is known: a parameter change draws it again for it
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        gui.system.module("colour").set_parameters(v_max=254)
    qtbot.waitUntil(lambda: view._display is not None, timeout=HANG_GUARD_MS)
    area = view.image_rect()
    scale = area.width() / WIDTH
    assert scale < 0.2  # really scaled down
    shot = view.grab().toImage().convertToFormat(QImage.Format.Format_RGB888)
    pixels = np.frombuffer(shot.constBits(), np.uint8).reshape(shot.height(), shot.bytesPerLine())
    rgb = pixels[:, : shot.width() * 3].reshape(shot.height(), shot.width(), 3)
    bgr = rgb[:, :, ::-1]
    ratio = shot.width() / view.width()  # a high-DPI grab has more pixels than the widget
    assert outline_share(bgr, round(area.left() * ratio), round(area.top() * ratio), scale * ratio) >= 0.9
