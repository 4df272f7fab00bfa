"""The window reaches data kinds through the kind contract only: a third kind (1-D signals, neither images
nor clouds) shows its stages, a source spec of several kinds waits for the pipeline's kind, a pipeline whose
kind changes gets that kind's demo source, and objrec_apps imports no kind package."""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from objrec_apps.define import starting_system
from objrec_core import (
    DetectedObjectArray,
    Detector,
    Filter,
    Float,
    Frame,
    FrameKindError,
    FrameSource,
    Int,
    Kind,
    RecognitionSystem,
    SourceSpec,
    get_kind,
    register_kind,
    register_source,
)
from objrec_core.registry import unregister_kind, unregister_source
from tests.qt_waits import HANG_GUARD_MS

HEIGHT = 64
LENGTH = 200


class SignalKind(Kind):
    """1-D float signals; a picture is the signal plotted in white, peaks marked by red columns."""

    name = "signal"
    title = "signals"
    demo_spec = "wave"

    def check_frame(self, data: Any) -> None:
        if not (isinstance(data, np.ndarray) and data.ndim == 1 and data.dtype.kind == "f"):
            raise FrameKindError(f"expected a 1-D float signal, got {type(data).__name__}")

    def preview(self, data: Any) -> np.ndarray:
        self.check_frame(data)
        picture = np.zeros((HEIGHT, data.size, 3), np.uint8)
        rows = np.clip(np.round((1.0 - data) * (HEIGHT - 1)), 0, HEIGHT - 1).astype(int)
        picture[rows, np.arange(data.size)] = 255
        return picture

    def annotate(self, frame: Frame, objects: DetectedObjectArray) -> np.ndarray:
        picture = self.preview(frame.data)
        for peak in objects.objects:
            picture[:, peak.index] = (0, 0, 255)
        return picture


@dataclass
class Peak:
    name: str
    index: int


class Smooth(Filter):
    """A moving average."""

    kind = "signal"
    width = Int(5, "samples averaged", min=1, max=31, step=2)

    def filter(self, frame: Any) -> np.ndarray:
        width = self.params.width
        return np.convolve(frame, np.ones(width) / width, mode="same")


class Peaks(Detector):
    """Local maxima above a threshold."""

    kind = "signal"
    threshold = Float(0.6, "lowest peak", min=0.0, max=1.0, step=0.05)

    def detect(self, frame: Any) -> list[Peak]:
        inner = frame[1:-1]
        found = np.flatnonzero((inner > frame[:-2]) & (inner >= frame[2:]) & (inner > self.params.threshold)) + 1
        return [Peak(self.object_name, int(i)) for i in found]


def wave(index: int) -> np.ndarray:
    x = np.linspace(0.0, 4 * np.pi, LENGTH)
    return (0.5 + 0.4 * np.sin(x + 0.1 * index)).astype(np.float64)


class WaveSource(FrameSource):
    """A moving sine wave: this kind's demo."""

    kind = "signal"
    schemes = ("wave",)
    options = {"frames": Int(None, "how many frames (none: endless)", min=1, optional=True)}  # noqa: RUF012
    summary = "wave[:frames=N], a moving sine"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> WaveSource:
        return cls(spec.text, options["frames"])

    def __init__(self, name: str = "wave", frames: int | None = None) -> None:
        self.name = name
        self.frames = frames

    def __iter__(self) -> Iterator[Frame]:
        counter = itertools.count() if self.frames is None else range(self.frames)
        for index in counter:
            yield Frame(wave(index), index=index, source=self.name)


@pytest.fixture
def signal_kind() -> Iterator[Kind]:
    kind = register_kind(SignalKind)
    register_source(WaveSource)
    yield kind
    unregister_source(WaveSource)
    unregister_kind("signal")


def test_a_third_kind_shows_every_stage(make_gui, qtbot, signal_kind):
    system = RecognitionSystem([Smooth("smooth"), Peaks("peaks")], object_name="peak")
    # Paused on the first frame: which frame a running wave shows depends on the machine's load, and from frame
    # 4 on the smoothed wave's edge holds a third maximum; frame 0 has the two peaks of the sine.
    gui = make_gui(system, source="wave", paused=True, first_frame=True, wait=False)
    assert gui.central.currentWidget() is gui.stage_views
    qtbot.waitUntil(lambda: list(gui.stage_views.views) == ["input", "smooth", "peaks"]
                    and gui.last_results is not None, timeout=HANG_GUARD_MS)
    assert gui.source_bar.name_label.text().strip() == "wave" and gui.worker.source_kind == "signal"
    results = gui.last_results
    assert results.frame.index == 0
    smoothed = results.stages[1].output
    assert np.array_equal(gui.stage_views.view("smooth").image(), signal_kind.preview(smoothed))
    peaks = [p.index for p in results.objects.objects]
    assert len(peaks) == 2 and all(p.name == "peak" for p in results.objects.objects)
    original = gui.stage_views.view("input").image()
    assert original.shape == (HEIGHT, LENGTH, 3)
    for index in peaks:  # the kind's annotation: a red column per peak
        assert (original[:, index] == (0, 0, 255)).all()
    assert gui.stage_views.tabs.tabText(2) == "peaks (Peaks): its input + detections"


def test_a_source_of_several_kinds_waits_for_the_pipelines_kind(make_gui, qtbot, signal_kind):
    gui = make_gui(None, wait=False)  # the default source, demo, is both a 2d and a 3d source
    message = gui.statusBar().currentMessage()
    assert message.startswith("demo is a source of images (2d) and point clouds (3d)")
    assert "add a module" in message
    assert gui.source_bar.name_label.text().strip() == "demo (waiting for a pipeline)"
    assert gui.stage_views.placeholder.text().startswith("demo is a source of images (2d) and point clouds (3d).")
    qtbot.wait(200)
    assert gui.worker.source is None and gui.last_results is None
    gui.system.add_module(Smooth("smooth"))  # now a signal pipeline: no signal source reads demo, its own demo
    assert gui.statusBar().currentMessage() == "no source of signals reads demo: opening wave…"
    qtbot.waitUntil(lambda: gui.source_bar.name_label.text().strip() == "wave", timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: list(gui.stage_views.views) == ["input", "smooth"], timeout=HANG_GUARD_MS)
    assert gui.worker.source_kind == "signal"


def test_a_pipeline_whose_kind_changes_opens_that_kinds_demo(make_gui, qtbot, signal_kind):
    gui = make_gui(starting_system("hsv"))
    assert gui.worker.source_kind == "2d" and list(gui.stage_views.views) == ["input", "colour", "open", "blobs"]
    gui.system.set_modules([Smooth("smooth"), Peaks("peaks")], kind="signal")
    assert gui.statusBar().currentMessage() == "the pipeline now works on signals: opening wave…"
    qtbot.waitUntil(lambda: list(gui.stage_views.views) == ["input", "smooth", "peaks"], timeout=HANG_GUARD_MS)
    assert gui.worker.source_kind == "signal" and gui.source_bar.name_label.text().strip() == "wave"
    assert gui.last_results.frame.data.shape == (LENGTH,)
    assert "(signal pipeline)" in gui.windowTitle()


def test_a_kind_whose_views_show_points_gets_the_3d_page(make_gui, qtbot):
    pytest.importorskip("objrec3d")
    assert get_kind("3d").has_points and not get_kind("2d").has_points
    gui = make_gui(starting_system("shape"), paused=True, wait=False)
    assert gui.central.currentWidget() is gui.view3d
    gui.system.set_modules(starting_system("hsv").modules, kind="2d")
    assert gui.central.currentWidget() is gui.stage_views


def test_objrec_apps_imports_no_kind_package():
    root = Path(__file__).resolve().parents[2] / "objrec_apps"
    pattern = re.compile(r"^\s*(import|from)\s+(objrec2d|objrec3d)\b|import_module\(\s*[\"'](objrec2d|objrec3d)",
                         re.MULTILINE)
    sources = sorted(root.rglob("*.py"))
    assert len(sources) >= 15
    offenders = [f"{path.relative_to(root.parent)}: {match.group(0).strip()}"
                 for path in sources for match in pattern.finditer(path.read_text(encoding="utf-8"))]
    assert offenders == []
