"""A detector's reason for finding nothing travels with its result (``Detections``), never as state read back
from the detector: one instance serves several threads, each getting its own frame's reason, and the
director, the --explain sink and the stage views read the reason of the frame they hold."""

from __future__ import annotations

import pickle
import sys
import threading

import numpy as np
import pytest

from objrec2d import BinaryDetector, DemoScene, FeatureDetector, ImageDetector
from objrec2d.messages import DetectedObject2D, Polygon
from objrec_core import DetectionDirector, RecognitionSystem, Rect
from objrec_core.modules import Detections, detection_reason

EMPTY_REASON = "no blob: the mask has no non-zero pixel (the filters before let nothing through)"
BORDER_REASON = "1 blob, none kept: 1 covering more than max_area_fraction 0.9 of the image (smallest 99%)"


def empty_mask() -> np.ndarray:
    return np.zeros((120, 160), np.uint8)


def full_mask() -> np.ndarray:
    return np.full((120, 160), 255, np.uint8)


def square_mask() -> np.ndarray:
    mask = empty_mask()
    mask[40:80, 60:100] = 255
    return mask


def test_detections_are_a_list_with_a_reason_only_when_empty():
    found = Detections(["a", "b"], reason="ignored: something was found")
    assert found == ["a", "b"] and found.reason is None and len(found) == 2
    nothing = Detections([], "too dark")
    assert nothing == [] and nothing.reason == "too dark" and not nothing
    again = pickle.loads(pickle.dumps(Detections([], "too dark", details={"best": 3})))
    assert type(again) is Detections and again.reason == "too dark" and again.details == {"best": 3}
    assert detection_reason(object(), nothing) == "too dark"
    assert detection_reason(object(), found) is None


def test_the_reason_is_returned_with_the_result():
    detector = BinaryDetector()
    assert detector.detect(empty_mask()).reason == EMPTY_REASON
    assert detector.detect(full_mask()).reason == BORDER_REASON
    found = detector.detect(square_mask())
    assert len(found) == 1 and found.reason is None


def test_two_threads_on_one_detector_each_get_their_own_frames_reason():
    """Before, the reason was kept on the detector and read back after ``detect``: a second thread's frame
    overwrote it in between. Each thread here checks every result it gets against its own frame."""
    detector = BinaryDetector()
    frames = {"empty": (empty_mask(), EMPTY_REASON, 0), "full": (full_mask(), BORDER_REASON, 0),
              "square": (square_mask(), None, 1)}
    start = threading.Barrier(3)
    wrong: list[tuple[str, int, str | None]] = []
    counts = dict.fromkeys(frames, 0)

    def work(name: str) -> None:
        frame, reason, objects = frames[name]
        start.wait()
        for _ in range(300):
            result = detector.detect(frame)
            if result.reason != reason or len(result) != objects:
                wrong.append((name, len(result), result.reason))
            counts[name] += 1

    threads = [threading.Thread(target=work, args=(name,)) for name in frames]
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)  # switch threads often: an interleaving has every chance
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(120)  # hang guard only
    finally:
        sys.setswitchinterval(switch)
    assert counts == dict.fromkeys(frames, 300)
    assert wrong == []


@pytest.mark.parametrize("make", [BinaryDetector, FeatureDetector], ids=["BinaryDetector", "FeatureDetector"])
def test_detecting_leaves_nothing_of_the_frame_on_the_detector(make):
    """No side door: after ``detect`` the instance holds exactly the attributes, and the same objects, it
    held before, whether the frame gave objects or a reason."""
    scene = DemoScene(seed=0)
    first, _ = scene.render(0)
    detector = make()
    if isinstance(detector, FeatureDetector):
        detector.process_area_selection(Rect(*scene.target.reference_rect), first)
        frames = [scene.render(5)[0], np.full_like(first, 128)]
    else:
        frames = [square_mask(), empty_mask(), full_mask()]
    detector.detect(frames[0])  # anything built once, on first use, is built now
    before = dict(vars(detector))
    results = [detector.detect(frame) for frame in frames]
    assert len(results[0]) == 1 and all(result == [] and result.reason for result in results[1:])
    assert vars(detector).keys() == before.keys()
    assert [name for name, value in before.items() if vars(detector)[name] is not value] == []


class Flicker(ImageDetector):
    """Finds one object in frames with a bright pixel, else gives the frame's mean as its reason."""

    def detect(self, frame):
        if frame.max() > 200:
            return Detections([DetectedObject2D(self.object_name, Polygon.from_xy([(0, 0), (1, 0), (1, 1)]))])
        return Detections([], f"too dark: mean {frame.mean():.1f}")


class OldStyle(ImageDetector):
    """A plug-in written before results carried reasons: a plain list, and its own ``last_reason``."""

    @property
    def last_reason(self):
        return "kept by the plug-in itself"

    def detect(self, frame):
        return []


def test_the_director_reports_each_frames_own_reason():
    system = RecognitionSystem([Flicker("flicker"), OldStyle("old")])
    director = DetectionDirector(system)
    heard = []
    director.add_outcome_sink(lambda header, outcomes: heard.append([(o.detector, o.found, o.reason)
                                                                      for o in outcomes]))
    for level in (10, 255, 30):
        director.process(np.full((8, 8), level, np.uint8))
    assert heard == [
        [("flicker", 0, "too dark: mean 10.0"), ("old", 0, "kept by the plug-in itself")],
        [("flicker", 1, None), ("old", 0, "kept by the plug-in itself")],
        [("flicker", 0, "too dark: mean 30.0"), ("old", 0, "kept by the plug-in itself")],
    ]


def test_stages_carry_the_reason_of_their_frame():
    system = RecognitionSystem([Flicker("flicker")])
    result = system.process(np.full((8, 8), 7, np.uint8), keep_stages=True)
    (stage,) = [s for s in result.stages if s.role == "detector"]
    assert stage.objects.reason == "too dark: mean 7.0" and result.reasons == {"flicker": "too dark: mean 7.0"}

