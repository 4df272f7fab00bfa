"""The quality strip: precision, recall and F1 of the current parameters over the labelled frames, live.

Tuning by eye says nothing about the frames not on screen; the strip does. After every parameter change (and
every label edit) the labelled frames are scored again with ``objrec_core.evaluation.run.score``, the same
function objrec-eval uses, so the figures agree with it to the last digit. The scoring runs in a thread of
its own on a copy of the system made from the parameters in force when the change was heard (the window's
worker keeps the original); a newer change stops the older computation, and a result is shown only if no
change came after the one it was computed for: a stale figure is never shown over newer parameters.

Frames are read once: those labelled on screen are kept by the label store; those of a label file opened
for a source are read from a fresh opening of the source with ``run.load_labelled`` the first time they are
scored, and kept.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import QLabel, QWidget

from objrec_core import Change, Frame, FrameSource, Kind, RecognitionSystem
from objrec_core.evaluation import run
from objrec_core.evaluation.scoring import Evaluation
from objrec_core.evaluation.truth import TruthSet
from objrec_core.tuning import copy_system

from .label_model import LabelStore
from .worker import UNSEEN_CHANGES

log = logging.getLogger(__name__)

#: Changes heard within this many milliseconds are scored once (a slider drag sends dozens).
SETTLE_MS = 120
#: What the strip says before any frame is labelled.
NO_LABELS = "Quality: no labelled frames (Tools > Label frames, or File > Open labels)"
#: The figures shown, as the scorer's summary columns.
FIGURES = ("precision", "recall", "f1")


def headline(evaluation: Evaluation) -> dict[str, float | None]:
    """Precision, recall and F1 over all names: the summary row named "all" (None where a figure is not
    defined: the precision of no detections at all)."""
    rows = evaluation.summary_rows()
    row = next((r for r in rows if "all" in (str(v) for v in r.values())), rows[-1] if rows else {})
    lowered = {str(k).lower(): v for k, v in row.items()}
    return {name: None if lowered[name] is None else float(lowered[name]) for name in FIGURES if name in lowered}


class _Watcher:
    """Hears the system's and its modules' changes (any thread) for the strip."""

    def __init__(self, strip: QualityStrip) -> None:
        self.strip: QualityStrip | None = strip

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        strip = self.strip
        if strip is not None and (not changes or any(c.name not in UNSEEN_CHANGES for c in changes)):
            strip.heard.emit(any(c.name == "pipeline" for c in changes))


ScoreFunction = Callable[..., Evaluation]


class QualityStrip(QLabel):
    """The figures of the current parameters over the labelled frames, for a toolbar or a status bar.

    ``kind()`` gives the pipeline's data kind (None: none yet), ``reopen()`` a fresh opening of the source on
    screen (None when it cannot be opened again: then only frames labelled on screen are scored).
    ``scored(evaluation, generation)`` is emitted when a result is shown; ``score_function`` is
    ``run.score`` (a test makes it slow).
    """

    heard = Signal(bool)
    _finished = Signal(int, object, object)
    scored = Signal(object, int)

    def __init__(self, system: RecognitionSystem, store: LabelStore, kind: Callable[[], Kind | None],
                 reopen: Callable[[], FrameSource | None], parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.system, self.store, self.kind, self.reopen = system, store, kind, reopen
        self.score_function: ScoreFunction = run.score
        #: The parameter generation asked for last, and the one whose figures are shown (-1: none).
        self.generation = 0
        self.shown_generation = -1
        #: Results computed for an older generation and dropped (a test counts them).
        self.dropped = 0
        self.evaluation: Evaluation | None = None
        #: Seconds the last shown computation took (copying the system and scoring).
        self.seconds = 0.0
        self._stop: threading.Event | None = None
        self._loaded: dict[int, Frame] = {}
        self._loaded_lock = threading.Lock()
        self._timer = QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.setInterval(SETTLE_MS)
        self._timer.timeout.connect(self.start)
        self._watcher = _Watcher(self)
        self._watched: tuple[Any, ...] = ()
        self.heard.connect(self._heard)
        self._finished.connect(self._done)
        self.store.changed.connect(self.schedule)
        system.add_observer(self._watcher)
        self._watch_modules()
        self.setMinimumWidth(300)
        self.setStyleSheet("QLabel { font-weight: bold; padding: 0px 8px; background: palette(alternate-base); }")
        self.setToolTip("Precision, recall and F1 of the current parameters over the labelled frames "
                        "(IoU 0.5), recomputed after every change")
        self.setText(NO_LABELS)

    # -- following the parameters ------------------------------------------------------------------------------
    def _watch_modules(self) -> None:
        modules = self.system.modules
        for module in self._watched:
            if not any(module is m for m in modules):
                module.remove_observer(self._watcher)
        for module in modules:
            module.add_observer(self._watcher)
        self._watched = modules

    def _heard(self, pipeline: bool) -> None:
        if pipeline:
            self._watch_modules()
        self.schedule()

    def detach(self) -> None:
        """Stop hearing the system (the window closes) and stop any computation."""
        self._watcher.strip = None
        self.system.remove_observer(self._watcher)
        for module in self._watched:
            module.remove_observer(self._watcher)
        self._watched = ()
        self._timer.stop()
        if self._stop is not None:
            self._stop.set()

    def schedule(self) -> None:
        """Something changed: a new generation, the running computation stopped, a new one soon."""
        self.generation += 1
        if self._stop is not None:
            self._stop.set()
        if not len(self.store):
            self.evaluation, self.shown_generation = None, -1
            self.setText(NO_LABELS)
            return
        self.setText(f"{self._figures_text()}  (scoring…)" if self.evaluation is not None else "scoring…")
        self._timer.start()

    # -- computing ---------------------------------------------------------------------------------------------
    def start(self) -> None:
        """Score the current parameters over the labelled frames, in a thread; now, without waiting."""
        self._timer.stop()
        kind = self.kind()
        if not len(self.store) or kind is None:
            return
        try:
            truth = self.store.to_truth(kind.name)
        except Exception as exc:  # the kind's truth objects refused a label: say so in the strip
            self.setText(f"labels not scored: {exc}")
            return
        frames = self.kept_frames()
        generation = self.generation
        stop = threading.Event()
        self._stop = stop
        thread = threading.Thread(target=self._compute, args=(generation, kind, truth, frames, stop),
                                  name=f"quality-{generation}", daemon=True)
        thread.start()

    def _compute(self, generation: int, kind: Kind, truth: TruthSet, frames: dict[int, Frame],
                 stop: threading.Event) -> None:
        started = time.perf_counter()
        try:
            with self.system.lock:
                system = copy_system(self.system)
            labelled = self.labelled(truth, frames, stop)
            evaluation = self.score_function(system, kind, labelled, stop=stop)
            outcome: Any = (evaluation, len(labelled), time.perf_counter() - started)
        except Exception as exc:
            log.debug("quality strip: scoring failed", exc_info=True)
            outcome = exc
        try:
            self._finished.emit(generation, outcome, stop)
        except RuntimeError:  # the strip was deleted meanwhile (its window closed): nobody to tell
            log.debug("quality strip: a computation ended after its window closed")

    def kept_frames(self) -> dict[int, Frame]:
        """The labelled frames in memory, by key (GUI thread): labelled on screen, or read once before."""
        with self._loaded_lock:
            return {**self._loaded, **self.store.frames}

    def labelled(self, truth: TruthSet, frames: dict[int, Frame], stop: threading.Event) -> list[run.Labelled]:
        """Each labelled frame with its truth (any thread): ``frames`` (from ``kept_frames``), and the others read
        once from the source, kept for next time."""
        key_of = (lambda f: f.stamp_ns) if truth.keyed_by == "stamp" else (lambda f: f.index)
        keyed = {(f.stamp_ns if truth.keyed_by == "stamp" else f.index): f for f in truth}
        missing = [label for key, label in keyed.items() if key not in frames]
        if missing:
            source = self.reopen()
            if source is not None:
                try:
                    for frame, _label in run.load_labelled(source, truth.subset(missing), stop):
                        frames[key_of(frame)] = frame
                        with self._loaded_lock:
                            self._loaded[key_of(frame)] = frame  # kept for the next computation
                finally:
                    source.close()
        return [(frames[key], label) for key, label in keyed.items() if key in frames]

    def _done(self, generation: int, outcome: Any, stop: threading.Event) -> None:
        if generation != self.generation or stop.is_set():
            self.dropped += 1  # computed for parameters since changed: never shown
            return
        if isinstance(outcome, Exception):
            self.setText(f"labels not scored: {outcome}")
            return
        evaluation, count, seconds = outcome
        self.evaluation, self.seconds, self.shown_generation = evaluation, seconds, generation
        missing = len(self.store) - count
        self.setText(self._figures_text() + (f" ({missing} labelled frames not found)" if missing else ""))
        self.scored.emit(evaluation, generation)

    def _figures_text(self) -> str:
        assert self.evaluation is not None
        figures = headline(self.evaluation)
        shown = "   ".join(f"{name.upper() if name == 'f1' else name.capitalize()} "
                           + ("—" if value is None else f"{value:.3f}") for name, value in figures.items())
        return f"Quality: {shown}   over {self.evaluation.frames} labelled frames"

    @property
    def figures(self) -> dict[str, float | None]:
        """The figures on show (empty before the first result)."""
        return headline(self.evaluation) if self.evaluation is not None else {}
