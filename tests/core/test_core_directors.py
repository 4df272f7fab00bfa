"""Directors: every stage reaches the definition view; selections reach detectors with the frame they saw;
sinks receive every array; a pipeline changed mid-run is picked up at the next frame."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

from objrec2d import BinaryDetector, HSVFilter, ImageDetector, MorphologyFilter
from objrec_core import (
    DefinitionDirector,
    DetectionDirector,
    Frame,
    JSONLinesSink,
    PipelineError,
    RecognitionSystem,
    Rect,
    SelectionRefused,
)


class SelectingDetector(ImageDetector):
    """Remembers the selection it was given; refuses selections that are too small."""

    kind = "2d"

    def __init__(self, id=None, **kw):
        self.selected = None
        super().__init__(id, **kw)

    def detect(self, frame):
        return []

    def process_area_selection(self, rect, frame):
        if rect.width < 10:
            raise SelectionRefused("too small to hold a target")
        self.selected = (rect, frame.shape)

    def render_debug(self, frame, objects):
        return np.full((2, 2), 7, np.uint8)


def picture():
    image = np.full((60, 80, 3), 128, np.uint8)
    image[10:30, 10:30] = (255, 0, 0)  # a blue square
    return image


class RecordingView:
    def __init__(self):
        self.results = []

    def show_stages(self, results):
        self.results.append(results)


def test_definition_view_sees_every_stage_and_the_debug_view():
    hsv = HSVFilter(id="hsv", h_min=100, h_max=130, s_min=100)
    selector = SelectingDetector(id="sel")
    system = RecognitionSystem([hsv, MorphologyFilter(id="m"), BinaryDetector(id="b"), selector], object_name="o")
    view = RecordingView()
    director = DefinitionDirector(system, view=view)
    director.process(picture())
    stages = view.results[0].stages
    assert [(s.id, s.role) for s in stages] == [
        ("input", "input"),
        ("hsv", "filter"),
        ("m", "filter"),
        ("b", "detector"),
        ("sel", "detector"),
    ]
    assert stages[1].output.ndim == 2 and stages[1].output[20, 20] == 255 and stages[1].output[50, 50] == 0
    assert len(stages[3].objects) == 1 and stages[3].debug is None
    assert stages[4].debug is not None and stages[4].debug[0, 0] == 7
    assert [o.name for o in view.results[0].objects.objects] == ["o"]


def test_area_selection_goes_to_each_detector_with_the_frame_it_saw():
    selector = SelectingDetector(id="sel")
    system = RecognitionSystem([HSVFilter(id="hsv"), selector])
    director = DefinitionDirector(system)
    early = director.process_area_selection(Rect(0, 0, 20, 20))
    assert early.refused == {"sel": "no frame has been processed yet"}
    director.process(picture())
    outcome = director.process_area_selection(Rect.from_corners(30, 25, 5, 2))
    assert outcome.accepted == ["sel"]
    assert selector.selected == (Rect(5, 2, 25, 23), (60, 80))  # the mask the detector saw, not the colour frame
    refused = director.process_area_selection(Rect(0, 0, 5, 5))
    assert refused.refused == {"sel": "too small to hold a target"}


def test_detection_director_feeds_sinks_with_sequenced_headers():
    stream = io.StringIO()
    received = []
    system = RecognitionSystem([HSVFilter(h_min=100, h_max=130, s_min=100), BinaryDetector()], object_name="sq")
    director = DetectionDirector(system, sinks=[JSONLinesSink(stream), received.append], frame_id="cam")
    arrays = list(director.run([Frame(picture(), stamp=10.5 + i) for i in range(3)]))
    assert [a.header.seq for a in received] == [0, 1, 2] and len(arrays) == 3
    lines = [json.loads(x) for x in stream.getvalue().splitlines()]
    assert [line["header"]["stamp"]["secs"] for line in lines] == [10, 11, 12]
    assert all(len(line["objects"]) == 1 for line in lines)


def test_a_module_added_while_running_applies_from_the_next_frame():
    # Asked for: the blob of the whole grey frame (touching the border, covering it all) counts as an object.
    system = RecognitionSystem([BinaryDetector(id="b", border_blobs=True, max_area_fraction=1.0)])
    director = DetectionDirector(system)
    frames = iter([picture()] * 2)
    assert len(director.process(next(frames)).objects) == 1  # the grey frame is one big blob
    system.add_module(HSVFilter(id="hsv", h_min=50, h_max=60, s_min=100), index=0)  # nothing is green
    assert len(director.process(next(frames)).objects) == 0


def test_running_without_a_detector_is_refused_and_bad_pipelines_too():
    with pytest.raises(PipelineError, match="no detector"):
        list(DetectionDirector(RecognitionSystem([HSVFilter()])).run([picture()]))
    with pytest.raises(PipelineError, match="id 'x'"):
        RecognitionSystem([HSVFilter(id="x"), BinaryDetector(id="x")])


def test_step_by_step_wiring():
    director = DetectionDirector()
    director.add_filter(HSVFilter(h_min=100, h_max=130, s_min=100))
    director.set_detector(BinaryDetector())
    director.add_filter(MorphologyFilter())
    assert [m.type_name for m in director.system.modules] == ["HSVFilter", "MorphologyFilter", "BinaryDetector"]
    assert len(director.process(picture()).objects) == 1


def test_max_frames_pulls_no_frame_beyond_the_limit():
    pulled = []

    def camera():
        for i in range(100):
            pulled.append(i)
            yield picture()

    director = DetectionDirector(RecognitionSystem([BinaryDetector()]))
    assert len(list(director.run(camera(), max_frames=2))) == 2
    assert pulled == [0, 1]


class CountingProgress:
    def __init__(self):
        self.events = []

    def start(self, total):
        self.events.append(("start", total))

    def advance(self, frames=1):
        self.events.append(("advance", frames))

    def close(self):
        self.events.append(("close",))


class ListSource(list):
    length = 5


def test_the_run_loop_counts_reports_progress_and_feeds_annotation_sinks():
    system = RecognitionSystem([HSVFilter(id="hsv", h_min=100, h_max=130, s_min=100), SelectingDetector(id="sel"),
                                BinaryDetector(id="blobs")], object_name="sq")
    pictures = []
    director = DetectionDirector(system, keep_stages=True,
                                 annotation_sinks=[lambda frame, array, stages: pictures.append(
                                     (frame.index, len(array.objects), [s.id for s in stages], stages[2].debug.sum()))])
    progress = CountingProgress()
    frames = ListSource(Frame(picture(), index=i, frame_id="optical") for i in range(5))
    stats = director.run_all(frames, max_frames=3, progress=progress)
    assert (stats.frames, stats.objects, stats.frames_with_objects, stats.stopped_by) == (3, 3, 3, "max_frames")
    assert stats.seconds > 0 and stats.rate == pytest.approx(3 / stats.seconds)
    assert progress.events == [("start", 3), ("advance", 1), ("advance", 1), ("advance", 1), ("close",)]
    assert pictures == [(i, 1, ["input", "hsv", "sel", "blobs"], 28) for i in range(3)]


def test_the_run_loop_stops_between_frames_and_headers_keep_the_frame_s_frame_id():
    import threading

    stop = threading.Event()
    received = []
    director = DetectionDirector(RecognitionSystem([BinaryDetector()]), frame_id="camera",
                                 sinks=[received.append, lambda _array: stop.set()])
    frames = [Frame(picture(), frame_id="optical"), Frame(picture()), Frame(picture())]
    stats = director.run_all(frames, stop=stop)
    assert (stats.frames, stats.stopped_by) == (1, "stop")
    assert received[0].header.frame_id == "optical"
    director = DetectionDirector(RecognitionSystem([BinaryDetector()]), frame_id="camera", sinks=[received.append])
    director.run_all(frames[1:2])
    assert received[-1].header.frame_id == "camera"
