"""Tools > Tune…: the dialog runs a few trials of the search on labelled demo frames in a thread, shows the
held-out score and the importance table, and applying the tuned values changes the panels in one undo step;
Cancel stops a long search after the trial under way."""

from __future__ import annotations

from itertools import islice

import pytest

from objrec_apps.define import starting_system
from objrec_apps.gui.label_model import from_truth_object
from objrec_core import get_kind, open_source
from tests.qt_waits import HANG_GUARD_MS

pytest.importorskip("optuna", reason="the tune extra (optuna) is not installed")
truth2d = pytest.importorskip("objrec2d.truth", reason="the 2D truth (objrec2d/truth.py) is not there yet")

FRAMES = 6
#: A start the search improves on: a saturation floor no shape reaches (nothing found, F1 0).
BAD_START = {"s_min": 250}
#: The one parameter searched (the others are checked "keep fixed"): any floor under the shapes' saturation
#: finds them, so a few random trials find a better one.
SEARCHED = "colour.s_min"


@pytest.fixture
def window(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    try:
        get_kind("2d").scorer()
    except LookupError:
        pytest.skip("the 2D kind has no scorer yet")
    with open_source("demo", "2d") as source:
        frames = list(islice(source, FRAMES))
    store = gui.labels.store
    for frame in frames:
        labels = [from_truth_object(o) for o in get_kind("2d").frame_truth(frame).objects]
        store.set_labels(frame.index, labels, frame)
    store.mark_saved(None)
    gui.system.module("colour").set_parameters(**BAD_START)
    gui.changes.forget()
    yield gui
    store.mark_saved(None)


def run_dialog(gui, qtbot, trials: int):
    gui.tune_action.trigger()
    dialog = gui.tune_dialog
    assert dialog.isVisible() and dialog.fixed.count() > 0
    dialog.trials.setValue(trials)
    dialog.seed.setValue(3)
    dialog.held_out.setValue(0.34)
    for i in range(dialog.fixed.count()):
        if dialog.fixed.item(i).text() != SEARCHED:
            dialog.fixed.item(i).setCheckState(dialog.fixed.item(i).checkState().Checked)
    return dialog


@pytest.mark.timeout(300)
def test_tune_a_few_trials_and_apply_in_one_undo_step(window, qtbot):
    gui = window
    dialog = run_dialog(gui, qtbot, 12)
    with qtbot.waitSignal(dialog.finished_tuning, timeout=HANG_GUARD_MS) as finished:
        assert dialog.start()
        assert dialog.running and dialog.cancel_button.isEnabled()
    result = finished.args[0]
    assert result is not None and result.trials == 12 and not result.stopped
    assert result.held_out_frames == 2 and result.searched_frames == 4
    assert dialog.progress.value() == 12
    assert "held-out score" in dialog.status.text()
    assert dialog.table.rowCount() == len(result.importance_rows()) > 0
    assert list(result.changed) == [SEARCHED]  # the fixed ones kept
    assert result.changed and dialog.apply_button.isEnabled()
    before = gui.system.module("colour").get_parameters()
    depth = gui.undo.stack.count()
    assert dialog.apply()
    colour = gui.system.module("colour").get_parameters()
    for key, (_start, tuned) in result.changed.items():
        assert colour[key.split(".", 1)[1]] == tuned
    editors = gui.panels.panel("colour").editors
    for key in result.changed:  # the panel shows the tuned values
        name = key.split(".", 1)[1]
        editor = editors[name]
        assert editor.value_at(editor.slider.value()) == colour[name]
    assert gui.undo.stack.count() == depth + 1  # one step, undone at once
    gui.undo_action.trigger()
    assert gui.system.module("colour").get_parameters() == before
    gui.changes.forget()


@pytest.mark.timeout(300)
def test_cancel_stops_the_search(window, qtbot):
    gui = window
    dialog = run_dialog(gui, qtbot, 5000)
    progressed = []
    dialog.progressed.connect(progressed.append)
    assert dialog.start()
    qtbot.waitUntil(lambda: len(progressed) >= 2, timeout=HANG_GUARD_MS)
    with qtbot.waitSignal(dialog.finished_tuning, timeout=HANG_GUARD_MS) as finished:
        dialog.cancel_button.click()
    result = finished.args[0]
    assert result is not None and result.stopped and result.trials < 5000
    assert not dialog.running and dialog.start_button.isEnabled()
    assert "cancelled" in dialog.status.text()
