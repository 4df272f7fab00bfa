"""The guard against PySide6 6.12's lost references to None/True/False on CPython 3.11, and the pictures
prepared off the GUI thread: a long session must neither abort nor show anything but the right pixels."""

from __future__ import annotations

import sys

import numpy as np
from PySide6.QtCore import QObject, Signal

from objrec_apps.define import starting_system
from objrec_apps.gui.compat import guard_none_refcount, singleton_leaks
from objrec_apps.gui.images import display_buffer, fit_size
from tests.qt_waits import HANG_GUARD_MS


class _Pinger(QObject):
    ping = Signal(bool)


def test_many_void_calls_and_emits_do_not_free_none_or_true():
    guard_none_refcount()  # applied on import where needed; a no-op on healthy bindings
    pinger = _Pinger()
    pinger.ping.connect(lambda value: None)
    for _ in range(50_000):  # far more than None's or True's own references on CPython 3.11
        pinger.setObjectName("x")
        pinger.ping.emit(True)
    assert sys.getrefcount(None) > 0 and sys.getrefcount(True) > 0
    leaks = singleton_leaks()
    assert set(leaks) == {"None", "bool"} and all(v in (0, 1) for v in leaks.values())


def test_display_buffers_are_scaled_bgrx_copies():
    image = np.zeros((480, 640, 3), np.uint8)
    image[:, :320] = (255, 0, 0)  # blue left half
    assert fit_size(640, 480, 590, 600) == (590, 442)
    buffer = display_buffer(image, (320, 240))
    assert buffer.shape == (240, 320, 4)
    assert tuple(buffer[120, 10]) == (255, 0, 0, 255) and tuple(buffer[120, 300]) == (0, 0, 0, 255)
    mask = display_buffer(np.full((480, 640), 255, np.uint8), (640, 480))
    assert mask.shape == (480, 640, 4) and (mask == 255).all()


def test_the_views_paint_frames_scaled_in_the_processing_thread(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), view_mode="grid")
    views = gui.stage_views.views
    qtbot.waitUntil(lambda: all(v._display is not None for v in views.values()), timeout=HANG_GUARD_MS)
    for key, view in views.items():
        area = view.image_rect()
        assert abs(view._display.width - area.width()) <= 1 and abs(view._display.height - area.height()) <= 1
        picture = view.grab().toImage()
        left, top = round(area.left()), round(area.top())
        width, height = view._display.width, view._display.height
        for x, y in ((5, 5), (width // 2, height // 3), (width * 2 // 3, height * 4 // 5)):
            shown = picture.pixelColor(left + x, top + y)
            expected = view._display.array[y, x]  # painted 1:1, no scaling in the GUI thread
            assert (shown.blue(), shown.green(), shown.red()) == tuple(int(c) for c in expected[:3]), key
