"""Every message seen whole: the message area keeps long errors in full (the status bar cuts them), the hover
read-out does not replace them, file errors also come as a dialog; per detector, why it found nothing; a
detector above a filter and a selection no detector takes are reported."""

from __future__ import annotations

import pytest
from PySide6.QtWidgets import QMessageBox

from objrec2d import FeatureDetector
from objrec_apps.define import starting_system
from objrec_core import Rect, SourceError, open_source
from tests.qt_waits import HANG_GUARD_MS


def test_a_long_error_is_kept_whole_and_the_hover_read_out_does_not_replace_it(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    spec = "demo:seed=3,frames=-300"
    with pytest.raises(SourceError) as raised:
        open_source(spec, "2d")
    expected = str(raised.value)
    assert len(expected) > 60  # longer than fits beside the read-outs
    gui.open_source(spec)
    qtbot.waitUntil(lambda: expected in gui.message_area.messages(), timeout=HANG_GUARD_MS)
    item = gui.message_area.list.item(gui.message_area.list.count() - 1)
    assert item.text().endswith("error: " + expected)
    gui.stage_views.hovered.emit("(12, 30)  BGR 10 20 30  HSV 110 170 30")
    assert gui.hover_label.text() == "(12, 30)  BGR 10 20 30  HSV 110 170 30"
    assert gui.message_area.messages()[-1] == expected


def test_the_message_area_keeps_the_last_messages(make_gui):
    gui = make_gui(starting_system("hsv"))
    area = gui.message_area
    area.keep = 5
    for number in range(8):
        gui.show_message(f"message {number}")
    assert area.messages() == [f"message {number}" for number in range(3, 8)]


def test_a_file_that_cannot_be_opened_says_why_in_a_dialog_too(make_gui, qtbot, tmp_path):
    gui = make_gui(starting_system("hsv"))
    broken = tmp_path / "broken.yaml"
    broken.write_text("format_version: 1\nkind: 2d\npipeline:\n- type: NoSuchFilter\n  id: x\n")
    assert not gui.files.open(broken)
    dialog = gui.message_area.dialog
    assert isinstance(dialog, QMessageBox) and dialog.isVisible()
    assert dialog.text().startswith("Not opened:") and "NoSuchFilter" in dialog.text()
    assert gui.message_area.messages()[-1] == dialog.text()
    dialog.close()


def test_each_detector_says_what_it_found_or_why_not(make_gui, qtbot):
    system = starting_system("hsv")
    system.set_modules([*system.modules, FeatureDetector("poster")])
    gui = make_gui(system)
    qtbot.waitUntil(lambda: "poster:" in gui.message_area.detector_text, timeout=HANG_GUARD_MS)
    text = gui.message_area.detector_text
    found = len(next(s for s in gui.last_results.stages if s.id == "blobs").objects)
    assert found >= 3  # the demo's coloured objects
    assert f"blobs: {found} objects" in text
    assert "poster: no target: select one" in text  # the feature detector's own reason, whole


def test_a_detector_moved_above_a_filter_is_reported(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    colour, opening, blobs = gui.system.modules
    gui.system.set_modules([colour, blobs, opening])
    qtbot.waitUntil(lambda: any(m.startswith("blobs comes before the filter open")
                                for m in gui.message_area.messages()), timeout=HANG_GUARD_MS)
    gui.system.set_modules([colour, opening])
    qtbot.waitUntil(lambda: any("the pipeline has no detector" in m for m in gui.message_area.messages()),
                    timeout=HANG_GUARD_MS)
    gui.changes.forget()  # the pipeline edits are not to be saved: close without the unsaved-changes question


def test_a_selection_no_detector_takes_says_so(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    gui.hand_selection(Rect(10, 10, 40, 30), None)
    qtbot.waitUntil(lambda: any("did nothing" in m for m in gui.message_area.messages()), timeout=HANG_GUARD_MS)
    message = gui.message_area.messages()[-1]
    assert message == ("selection 40×30 at (10, 10) did nothing: no detector in the pipeline takes selections "
                       "(blobs ignores them); add one that learns a target (a feature detector) from the "
                       "Pipeline menu; or, to set an HSV filter's ranges from the pixels in the rectangle, drag "
                       "with the HSV eyedropper (Ctrl+E, or hold Shift while dragging)")  # names the eyedropper
