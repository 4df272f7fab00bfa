"""The FeatureDetector panel's status line tells what the detector made of the frame on screen, read from that
frame's results (its reason, its attempt's inlier count), never back from the detector: a worker may be
running the detector on a newer frame meanwhile, and the detector keeps nothing of a frame."""

from __future__ import annotations

import numpy as np

from objrec2d import DemoScene, FeatureDetector
from objrec_apps.define import starting_system
from objrec_apps.gui import create_panel
from objrec_apps.gui.feature_panel import frame_status
from objrec_core import DetectedObjectArray, Frame, Header, RecognitionSystem, Rect, StageResults
from tests.qt_waits import HANG_GUARD_MS

NO_TARGET = "no target: select one in objrec-define (drag a rectangle around the object)"
NO_KEYPOINTS = "too few keypoints in the frame: 0 ORB keypoints, min_matches is 10 (a plain, dark or blurred frame?)"


def results_of(system: RecognitionSystem, image: np.ndarray) -> StageResults:
    """The results a definition view gets for ``image``: every stage kept."""
    found = system.process(image, keep_stages=True)
    return StageResults(Frame(image), found.stages, DetectedObjectArray(Header(), found.objects), 0.0)


def poster_system() -> tuple[RecognitionSystem, np.ndarray]:
    """A pipeline of one FeatureDetector with the demo poster selected in frame 0, and frame 0."""
    scene = DemoScene(seed=0)
    first, _ = scene.render(0)
    detector = FeatureDetector("poster")
    detector.process_area_selection(Rect(*scene.target.reference_rect), first)
    return RecognitionSystem([detector]), first


def test_the_status_line_reads_the_frames_results():
    system, first = poster_system()
    shown = results_of(system, first)
    (stage,) = shown.stages[1:]
    inliers = stage.objects.details[0].inlier_count
    assert inliers >= 10 and len(stage.objects) == 1
    assert frame_status("poster", shown) == f"Last frame: found ({inliers} inliers)"
    assert frame_status("poster", results_of(system, np.full_like(first, 128))) == f"Last frame: {NO_KEYPOINTS}"
    untrained = RecognitionSystem([FeatureDetector("poster")])
    assert frame_status("poster", results_of(untrained, first)) == f"Last frame: {NO_TARGET}"
    assert frame_status("other", shown) == ""  # not this panel's detector
    assert frame_status("poster", None) == ""  # no frame on screen yet


def test_the_panel_shows_the_frame_it_was_given_not_the_detectors_latest_call(qtbot):
    system, first = poster_system()
    (detector,) = system.detectors
    panel = create_panel(detector)
    qtbot.addWidget(panel)
    panel.show()
    panel.show_status()
    assert panel.status.text() == ""  # nothing on screen yet
    shown = results_of(system, first)
    panel.show_results(shown)
    assert detector.detect(np.full_like(first, 128)).reason == NO_KEYPOINTS  # a newer frame, not on screen
    panel.show_status()
    inliers = shown.stages[1].objects.details[0].inlier_count
    assert panel.status.text() == f"Last frame: found ({inliers} inliers)"
    panel.detach()


def test_the_window_feeds_the_panel_the_frame_on_screen(make_gui, qtbot):
    system = starting_system("hsv")
    system.set_modules([*system.modules, FeatureDetector("poster")])
    gui = make_gui(system)
    panel = gui.panels.panel("poster")
    qtbot.waitUntil(lambda: panel.status.text() == f"Last frame: {NO_TARGET}", timeout=HANG_GUARD_MS)
    stage = next(s for s in gui.last_results.stages if s.id == "poster")
    assert stage.objects == [] and stage.objects.reason == NO_TARGET
