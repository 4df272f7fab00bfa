"""Tools > Tune…: let the system search its own parameters on the labelled frames (objrec_core.tuning).

The dialog asks for the trials, the seed, the share of labelled frames held out (never seen by the search:
their score is the one reported) and the parameters to keep as they are; the search runs in a thread of its
own on a copy of the system (the window keeps working, with a progress bar and Cancel, which keeps the best
found so far). At the end it shows the held-out score and which parameters mattered, and offers to apply
the tuned values to the window's system as ONE undo step.
"""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING, Any

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QDoubleSpinBox,
    QFormLayout,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QProgressBar,
    QPushButton,
    QSpinBox,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
)

from objrec_core.tuning import (
    SearchSpaceError,
    TuningError,
    TuningProgress,
    TuningResult,
    TuningUnavailable,
    apply_values,
    copy_system,
    search_space,
    tune,
)

if TYPE_CHECKING:
    from .main_window import DefinitionGUI

log = logging.getLogger(__name__)

#: The importance table's columns (TuningResult.importance_rows).
COLUMNS = ("parameter", "importance", "start", "tuned")


class TuneDialog(QDialog):
    """The tuning dialog of one definition window. ``progressed(TuningProgress)`` after each trial and
    ``finished_tuning(result or None)`` at the end are emitted in the GUI thread."""

    progressed = Signal(object)
    finished_tuning = Signal(object)
    _done = Signal(object)

    def __init__(self, window: DefinitionGUI) -> None:
        super().__init__(window)
        self.window = window
        self.setWindowTitle("Tune the parameters")
        self.setObjectName("tune_dialog")
        self.result_: TuningResult | None = None
        self.stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._busy = False

        layout = QVBoxLayout(self)
        layout.addWidget(QLabel(
            "Search the parameters that score best on the labelled frames (Optuna's TPE sampler). The held-out "
            "frames are never seen by the search: their score is the one reported."))
        form = QFormLayout()
        self.trials = QSpinBox()
        self.trials.setRange(1, 10000)
        self.trials.setValue(100)
        form.addRow("Trials", self.trials)
        self.seed = QSpinBox()
        self.seed.setRange(0, 2**31 - 1)
        form.addRow("Seed", self.seed)
        self.held_out = QDoubleSpinBox()
        self.held_out.setRange(0.0, 0.9)
        self.held_out.setSingleStep(0.05)
        self.held_out.setValue(0.3)
        self.held_out.setToolTip("The share of labelled frames kept out of the search (0: none)")
        form.addRow("Held-out share", self.held_out)
        self.fixed = QListWidget()
        self.fixed.setToolTip("Checked parameters keep their current values")
        try:
            keys = search_space(window.system.modules).keys
        except SearchSpaceError as exc:
            keys = []
            layout.addWidget(QLabel(f"The search space: {exc}"))
        for key in keys:
            item = QListWidgetItem(key)
            item.setFlags(item.flags() | Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(Qt.CheckState.Unchecked)
            self.fixed.addItem(item)
        form.addRow("Keep fixed", self.fixed)
        layout.addLayout(form)
        self.progress = QProgressBar()
        self.progress.setFormat("%v / %m trials")
        layout.addWidget(self.progress)
        self.status = QLabel(f"{len(window.labels.store)} labelled frames")
        self.status.setWordWrap(True)
        layout.addWidget(self.status)
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels(list(COLUMNS))
        self.table.horizontalHeader().setStretchLastSection(True)
        layout.addWidget(self.table)
        buttons = QDialogButtonBox()
        self.start_button = QPushButton("Start")
        self.cancel_button = QPushButton("Cancel")
        self.apply_button = QPushButton("Apply tuned parameters")
        self.close_button = QPushButton("Close")
        for button in (self.start_button, self.cancel_button, self.apply_button, self.close_button):
            buttons.addButton(button, QDialogButtonBox.ButtonRole.ActionRole)
        self.cancel_button.setEnabled(False)
        self.apply_button.setEnabled(False)
        self.start_button.clicked.connect(self.start)
        self.cancel_button.clicked.connect(self.cancel)
        self.apply_button.clicked.connect(self.apply)
        self.close_button.clicked.connect(self.close)
        layout.addWidget(buttons)
        self.progressed.connect(self._show_progress)
        self._done.connect(self._finished)
        self.resize(560, 560)

    # -- the search -------------------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """A search started and its end not yet shown."""
        return self._busy

    def fixed_names(self) -> list[str]:
        return [self.fixed.item(i).text() for i in range(self.fixed.count())
                if self.fixed.item(i).checkState() == Qt.CheckState.Checked]

    def start(self) -> bool:
        """Start the search in a thread; False (and why, in the dialog) when it cannot start."""
        if self.running:
            return False
        kind = self.window.quality.kind()
        store = self.window.labels.store
        if kind is None or not len(store):
            self.status.setText("No labelled frames: label some (Tools > Label frames) or open a label file "
                                "(File > Open labels) first.")
            return False
        truth = store.to_truth(kind.name)
        kept = self.window.quality.kept_frames()
        with self.window.system.lock:
            system = copy_system(self.window.system)  # the values now: the search never touches the window's
        options = dict(trials=self.trials.value(), seed=self.seed.value(), held_out=self.held_out.value(),
                       fix=self.fixed_names())
        self.stop = threading.Event()
        self.result_ = None
        self.table.setRowCount(0)
        self.progress.setRange(0, options["trials"])
        self.progress.setValue(0)
        self.status.setText(f"Tuning on {len(store)} labelled frames…")
        self.start_button.setEnabled(False)
        self.apply_button.setEnabled(False)
        self.cancel_button.setEnabled(True)
        stop = self.stop

        def search() -> None:
            try:
                frames = self.window.quality.labelled(truth, kept, stop)
                outcome: Any = tune(system, kind, frames, stop=stop, progress=self.progressed.emit, **options)
            except (TuningError, TuningUnavailable, SearchSpaceError, ValueError) as exc:
                outcome = exc
            except Exception as exc:  # a module failing on a frame: said in the dialog, logged whole
                log.exception("tuning failed")
                outcome = exc
            try:
                self._done.emit(outcome)
            except RuntimeError:  # the dialog was deleted meanwhile (its window closed): nobody to tell
                log.debug("tuning ended after its dialog closed")

        self._busy = True
        self._thread = threading.Thread(target=search, name="tune", daemon=True)
        self._thread.start()
        return True

    def cancel(self) -> None:
        """Stop after the trial under way; the best so far is still scored and offered."""
        self.stop.set()
        self.cancel_button.setEnabled(False)
        self.status.setText("Stopping after the trial under way…")

    def _show_progress(self, progress: TuningProgress) -> None:
        self.progress.setValue(progress.trial)
        best = "-" if progress.best is None else f"{progress.best:.3f}"
        broken = f", {progress.broken} broke a rule" if progress.broken else ""
        self.status.setText(f"Trial {progress.trial} of {progress.trials}: best score so far {best}{broken}")

    def _finished(self, outcome: Any) -> None:
        self._busy = False
        self.start_button.setEnabled(True)
        self.cancel_button.setEnabled(False)
        if isinstance(outcome, Exception):
            self.status.setText(f"Tuning failed: {outcome}")
            self.finished_tuning.emit(None)
            return
        result: TuningResult = outcome
        self.result_ = result
        stopped = " (cancelled: the best so far)" if result.stopped else ""
        self.status.setText(f"{result.trials} trials{stopped}: {result.score_line()}. "
                            f"{len(result.changed)} parameters changed.")
        rows = result.importance_rows()
        self.table.setRowCount(len(rows))
        for r, row in enumerate(rows):
            for c, cell in enumerate(row):
                self.table.setItem(r, c, QTableWidgetItem(cell))
        self.table.resizeColumnsToContents()
        self.apply_button.setEnabled(bool(result.changed))
        self.finished_tuning.emit(result)

    def apply(self) -> bool:
        """Give the window's system the tuned values: every module at once, ONE undo step."""
        result = self.result_
        if result is None:
            return False
        values = {module.id: module.get_parameters() for module in result.system.modules}
        stack = self.window.undo.stack
        stack.beginMacro(f"apply tuned parameters ({result.score_line()})")
        try:
            apply_values(self.window.system, values)
        except ValueError as exc:
            self.status.setText(f"Not applied: {exc}")
            return False
        finally:
            stack.endMacro()
        self.window.show_message(f"tuned parameters applied: {result.score_line()}")
        self.apply_button.setEnabled(False)
        return True

    def done(self, code: int) -> None:
        """Closing the dialog stops a search under way (its thread ends after the trial)."""
        self.stop.set()
        super().done(code)
