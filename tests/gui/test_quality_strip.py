"""The quality strip: its figures over the labelled frames equal ``run.score``'s for the same frames and
parameters, a parameter change brings new figures, and a result computed for parameters since changed is
dropped, never shown."""

from __future__ import annotations

import threading
from itertools import islice

import pytest

from objrec_apps.define import starting_system
from objrec_apps.gui.label_model import from_truth_object
from objrec_apps.gui.quality_strip import headline
from objrec_core import get_kind, open_source
from objrec_core.evaluation import run
from objrec_core.tuning import copy_system
from tests.qt_waits import HANG_GUARD_MS

truth2d = pytest.importorskip("objrec2d.truth", reason="the 2D truth (objrec2d/truth.py) is not there yet")

FRAMES = 6


def demo_frames(count: int = FRAMES) -> list:
    with open_source("demo", "2d") as source:
        return list(islice(source, count))


def expected(system, frames) -> dict[str, float | None]:
    """What objrec-eval's function says of these frames and these parameters, computed here."""
    kind = get_kind("2d")
    labelled = [(frame, get_kind("2d").frame_truth(frame)) for frame in frames]
    return headline(run.score(copy_system(system), kind, labelled))


@pytest.fixture
def window(make_gui, qtbot):
    """A colour-system window whose label store holds the demo's own truth of its first frames."""
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    try:
        get_kind("2d").scorer()
    except LookupError:
        pytest.skip("the 2D kind has no scorer yet")
    frames = demo_frames()
    store = gui.labels.store
    for frame in frames:
        labels = [from_truth_object(o) for o in get_kind("2d").frame_truth(frame).objects]
        store.set_labels(frame.index, labels, frame)
    store.mark_saved(None)
    yield gui, frames
    store.mark_saved(None)


def wait_scored(qtbot, strip, after: int) -> None:
    qtbot.waitUntil(lambda: strip.shown_generation > after and strip.shown_generation == strip.generation,
                    timeout=HANG_GUARD_MS)


@pytest.mark.timeout(180)
def test_figures_equal_run_score_and_follow_a_change(window, qtbot):
    gui, frames = window
    strip = gui.quality
    wait_scored(qtbot, strip, -1)
    assert strip.isVisible()
    figures = strip.figures
    assert set(figures) == {"precision", "recall", "f1"}
    assert figures == expected(gui.system, frames)
    assert strip.evaluation.frames == FRAMES
    assert f"over {FRAMES} labelled frames" in strip.text()

    # A saturation floor no pixel reaches: nothing is found, recall falls to 0.
    shown = strip.shown_generation
    gui.system.module("colour").set_parameters(s_min=255, s_max=255, v_min=255, v_max=255)
    wait_scored(qtbot, strip, shown)
    assert strip.figures == expected(gui.system, frames)
    assert strip.figures["recall"] == 0.0 and figures["recall"] > 0.5


@pytest.mark.timeout(180)
def test_a_stale_result_is_dropped(window, qtbot):
    gui, frames = window
    strip = gui.quality
    wait_scored(qtbot, strip, -1)
    first = strip.shown_generation
    release, entered = threading.Event(), threading.Event()
    calls = {"n": 0}

    def slow_first(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 1:  # the computation for the first change waits until the second change is made
            entered.set()
            assert release.wait(HANG_GUARD_MS / 1000)
        return run.score(*args, **kwargs)

    strip.score_function = slow_first
    colour = gui.system.module("colour")
    colour.set_parameters(s_min=255, s_max=255, v_min=255, v_max=255)  # nothing found
    strip.start()  # at once, not after the settling delay
    qtbot.waitUntil(entered.is_set, timeout=HANG_GUARD_MS)
    stale = strip.generation
    gui.undo_action.trigger()  # back to the shipped values while the first is still computing
    assert strip.generation > stale
    release.set()
    wait_scored(qtbot, strip, first)
    qtbot.waitUntil(lambda: strip.dropped >= 1, timeout=HANG_GUARD_MS)
    assert strip.shown_generation == strip.generation != stale
    assert strip.figures == expected(gui.system, frames)
    assert strip.figures["recall"] > 0.5  # the shipped values' figures, not the stale "nothing found"


@pytest.mark.timeout(180)
def test_a_label_file_opened_is_scored_on_frames_read_from_the_source(window, make_gui, qtbot, tmp_path):
    gui, frames = window
    path = tmp_path / "demo.json"
    assert gui.labels.save(str(path))
    other = make_gui(starting_system("hsv"), paused=True, wait=False)  # its source: the demo, nothing on screen
    assert other.labels.open(str(path))
    assert other.labels.store.frames == {}  # no frame kept: the strip reads them from the source once
    wait_scored(qtbot, other.quality, -1)
    assert other.quality.evaluation.frames == FRAMES
    assert other.quality.figures == expected(other.system, frames)
    assert "not found" not in other.quality.text()
