"""Replacing a running 3D pipeline by a 2D file never feeds a cloud to the 2D pipeline."""

from __future__ import annotations

import sys

import pytest

from objrec_apps.define import starting_system
from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("objrec3d")
pytest.importorskip("objrec2d")


def worker_waits_to_process() -> bool:
    """Whether some thread stands in ProcessingWorker._process (past its check of the frame's kind: the test
    holds the processing lock, so that is where it waits)."""
    for frame in sys._current_frames().values():
        while frame is not None:
            if frame.f_code.co_name == "_process" and frame.f_code.co_filename.endswith("worker.py"):
                return True
            frame = frame.f_back
    return False


def kind_errors(gui) -> list[str]:
    return [text for text in gui.message_area.messages() if "processing frame" in text and "failed" in text]


@pytest.mark.timeout(300)
def test_opening_a_2d_file_over_a_running_3d_pipeline_processes_no_cloud_in_it(make_gui, qtbot, project_root):
    gui = make_gui(starting_system("shape"), wait=False)
    qtbot.waitUntil(lambda: gui.last_results is not None, timeout=HANG_GUARD_MS)  # clouds are being processed
    assert gui.files.open(project_root / "params" / "hsv_demo.yaml")
    assert gui.system.kind == "2d"
    qtbot.waitUntil(lambda: gui.last_results is not None and gui.last_results.frame.data.__class__.__name__
                    == "ndarray", timeout=HANG_GUARD_MS)  # the 2D demo plays now
    assert kind_errors(gui) == []


@pytest.mark.timeout(300)
def test_a_pipeline_replaced_while_a_cloud_waits_for_the_processing_lock_skips_it(make_gui, qtbot, project_root):
    """The replacement race made certain: the worker has checked that the frame's kind is the pipeline's and
    waits for the processing lock, which the window holds while it replaces the pipeline by a 2D one."""
    from objrec_core import build_system

    gui = make_gui(starting_system("shape"), wait=False)
    qtbot.waitUntil(lambda: gui.last_results is not None, timeout=HANG_GUARD_MS)
    flat = build_system(project_root / "params" / "hsv_demo.yaml")
    processed = gui.worker.processed
    with gui.worker.exclusive():
        qtbot.waitUntil(worker_waits_to_process, timeout=HANG_GUARD_MS)  # it has a cloud, checked, in hand
        gui.system.set_modules(list(flat.modules), kind="2d")
    qtbot.waitUntil(lambda: gui.director.skipped >= 1, timeout=HANG_GUARD_MS)  # the cloud in hand: skipped
    qtbot.waitUntil(lambda: gui.worker.processed > processed, timeout=HANG_GUARD_MS)  # images come next
    assert kind_errors(gui) == []
