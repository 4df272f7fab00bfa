"""Source controls: choose the demo, a camera, a file, a folder, a live topic or any source spec; pause, resume,
single step, and restart a source that ended; fps. The file dialog offers what the installed source types of the
pipeline's kind read; a live topic is chosen in the window's File > Open topic dialog (``topicRequested``)."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import Signal
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QComboBox, QFileDialog, QLabel, QLineEdit, QPushButton, QSpinBox, QToolBar, QWidget

from objrec_core import source_entries, source_usage

from .topic_chooser import is_live_spec

KINDS = ("demo", "camera", "file", "folder", "topic", "spec")
PAUSE_TIP = "Pause or resume the source (Space); parameter changes still apply"
RESTART_TIP = ("The source ended: play it again from its first frame (Space); parameter changes still apply to the "
               "last frame on screen")


#: Put in the status bar before the error of a source that stopped at a frame it cannot read (the error is cut
#: at the bar's right end, this is not).
ENDED_HERE = "Ended (Restart plays it again from the start)"


def ended_message(name: str) -> str:
    """What the status bar says when a source gave its last frame: that it ended, and what the user can do now."""
    return (f"{name} ended: Restart (Space) plays it again from the start; parameter changes still apply to the "
            "frame on screen")


def file_filter(kind: str | None) -> str:
    """The open dialog's filter: the extensions the source types of ``kind`` (None: of every kind) read."""
    extensions = sorted({e for t in source_entries(kind).values() for e in t.extensions})
    patterns = " ".join(f"*{e}" for e in extensions)
    what = f"Files {kind} sources read" if kind else "Files the installed sources read"
    return f"{what} ({patterns});;All files (*)" if patterns else "All files (*)"


def chooser_kind(name: str) -> str:
    """Which entry of the chooser an open source's name is: demo, camera, file, folder, a live topic, or any
    other spec."""
    head = name.partition(":")[0].lower()
    if is_live_spec(name):
        return "topic"
    if head == "demo":
        return "demo"
    if head == "camera" and name.partition(":")[2].isdigit():
        return "camera"
    path = Path(name).expanduser()
    if path.is_dir():
        return "folder"
    if path.is_file():
        return "file"
    return "spec"


class FrameRate:
    """Frames shown per second over the last second or so (a moving window, not a lifetime mean)."""

    def __init__(self, window: float = 1.0) -> None:
        self.window = window
        self._stamps: deque[float] = deque()

    def tick(self, now: float) -> None:
        self._stamps.append(now)
        while self._stamps and now - self._stamps[0] > self.window:
            self._stamps.popleft()

    def reset(self) -> None:
        """Frames stopped coming (paused, ended): the next rate counts from the next frames only."""
        self._stamps.clear()

    def rate(self) -> float:
        if len(self._stamps) < 2:
            return 0.0
        span = self._stamps[-1] - self._stamps[0]
        return (len(self._stamps) - 1) / span if span > 0 else 0.0


class SourceBar(QToolBar):
    """Emits ``sourceRequested(spec)`` with a source spec (``demo``, ``camera:N``, a path, or any spec typed
    in); the window opens it. ``last_folder`` gives where file dialogs start, ``kind`` the pipeline's data
    kind (None while it has none)."""

    sourceRequested = Signal(str)  # noqa: N815 - Qt's signal naming
    pauseToggled = Signal(bool)  # noqa: N815 - Qt's signal naming
    stepRequested = Signal()  # noqa: N815 - Qt's signal naming
    folderUsed = Signal(str)  # noqa: N815 - Qt's signal naming
    topicRequested = Signal()  # noqa: N815 - Qt's signal naming: list the live topics to choose one
    restartRequested = Signal()  # noqa: N815 - Qt's signal naming: play the ended source again from its start

    def __init__(self, last_folder: Callable[[], str], parent: QWidget | None = None,
                 kind: Callable[[], str | None] = lambda: None) -> None:
        super().__init__("Source", parent)
        self.setObjectName("source_bar")
        self.last_folder = last_folder
        self.pipeline_kind = kind
        self.addWidget(QLabel(" Source "))
        self.kind = QComboBox()
        self.kind.addItems(list(KINDS))
        self.kind.setToolTip("demo: the built-in synthetic scene; camera: a camera by number; file: a file a "
                             "source reads; folder: a folder of them; topic: a live ROS 1 or ROS 2 topic; "
                             "spec: any source spec, typed in")
        self.kind.currentTextChanged.connect(self._kind_changed)
        self.addWidget(self.kind)
        self.camera_number = QSpinBox()
        self.camera_number.setRange(0, 63)
        self.camera_number.setPrefix("camera ")
        self.camera_action = self.addWidget(self.camera_number)
        self.camera_action.setVisible(False)
        self.spec_edit = QLineEdit()
        self.spec_edit.setPlaceholderText("demo:seed=3 · rgbd:color.png,depth.png · …")
        self.spec_edit.setMinimumWidth(220)
        self.spec_edit.returnPressed.connect(self.request)
        self.spec_action = self.addWidget(self.spec_edit)
        self.spec_action.setVisible(False)
        self.open_button = QPushButton("Open")
        self.open_button.setToolTip("Open the chosen source")
        self.open_button.clicked.connect(self.request)
        self.addWidget(self.open_button)
        self.name_label = QLabel()
        self.name_label.setMinimumWidth(120)
        self.addWidget(self.name_label)
        self.addSeparator()
        #: Whether the source on screen ended (its last frame shown, no more to come), and whether it is paused.
        self.ended = False
        self._paused = False
        self._name = ""
        self.pause_action = QAction("Pause", self)
        self.pause_action.setCheckable(True)
        self.pause_action.setShortcut(QKeySequence("Space"))
        self.pause_action.setToolTip(PAUSE_TIP)
        self.pause_action.toggled.connect(self._pause_toggled)
        self.addAction(self.pause_action)
        self.step_action = QAction("Step", self)
        self.step_action.setShortcut(QKeySequence("Ctrl+Right"))
        self.step_action.setToolTip("Pause and process exactly one new frame (Ctrl+Right)")
        self.step_action.triggered.connect(self.stepRequested)
        self.addAction(self.step_action)
        self.addSeparator()
        self.fps_label = QLabel()
        sample = self._rates_text(999.9, 9999.9, 999999)  # a live topic's " of N received" may widen it
        self.fps_label.setMinimumWidth(self.fps_label.fontMetrics().horizontalAdvance(sample) + 8)
        self.addWidget(self.fps_label)
        #: The last rates shown (processing ms, dropped, live counts) and why no frames come ("" while they do).
        self._last: tuple[float, int, tuple[int, int] | None] | None = None
        self._stopped = ""

    def _kind_changed(self, kind: str) -> None:
        self.camera_action.setVisible(kind == "camera")
        self.spec_action.setVisible(kind == "spec")
        if kind == "spec":
            self.spec_edit.setToolTip(f"Accepted: {source_usage(self.pipeline_kind())}")
        self.open_button.setText("Open…" if kind in ("file", "folder", "topic") else "Open")

    def request(self) -> None:
        """Turn the chosen kind into a spec (asking for the path where needed) and emit it."""
        kind = self.kind.currentText()
        if kind == "topic":
            self.topicRequested.emit()
            return
        if kind == "demo":
            spec = "demo"
        elif kind == "camera":
            spec = f"camera:{self.camera_number.value()}"
        elif kind == "spec":
            spec = self.spec_edit.text().strip()
        elif kind == "file":
            spec, _ = QFileDialog.getOpenFileName(self, "Open a source file", self.last_folder(),
                                                  file_filter(self.pipeline_kind()))
        else:
            spec = QFileDialog.getExistingDirectory(self, "Open a folder of source files", self.last_folder())
        if spec:
            if kind in ("file", "folder"):
                self.folderUsed.emit(spec)
            self.sourceRequested.emit(spec)

    def _pause_toggled(self, paused: bool) -> None:
        if self.ended:  # nothing left to pause or resume: the button offers the start again
            self._show_play_state()
            self.restartRequested.emit()
            return
        self._paused = paused
        self._show_play_state()
        self.pauseToggled.emit(paused)

    def _show_play_state(self) -> None:
        """The play/pause button as the source stands: Pause while it plays, Resume while paused, and Restart
        once it ended (a Pause there would pause nothing). Unchecked while ended, so any press restarts."""
        self.pause_action.blockSignals(True)
        self.pause_action.setChecked(self._paused and not self.ended)
        self.pause_action.blockSignals(False)
        self.pause_action.setText("Restart" if self.ended else "Resume" if self._paused else "Pause")
        self.pause_action.setToolTip(RESTART_TIP if self.ended else PAUSE_TIP)

    def set_paused(self, paused: bool) -> None:
        self._paused = paused
        self._show_play_state()

    def set_ended(self, ended: bool) -> None:
        """The source on screen ended (no more frames; its last one stays on screen), or plays again (a seek or
        a restart): the name says "(ended)" and the play/pause button offers Restart while it has."""
        self.ended = ended
        self.name_label.setText(f" {self._name} (ended) " if ended else f" {self._name} ")
        self._show_play_state()

    def set_source_name(self, name: str, ended: bool = False) -> None:
        """Show the open source's own name (``demo:seed=3``, a file's path), and set the chooser to what it
        is, so the bar never says "demo" with a file open (however the source was opened)."""
        self._name = name
        self.set_ended(ended)
        self.name_label.setToolTip(name)
        chosen = chooser_kind(name)
        if self.kind.currentText() != chosen:
            self.kind.blockSignals(True)
            self.kind.setCurrentText(chosen)
            self.kind.blockSignals(False)
            self._kind_changed(chosen)
        if chosen in ("spec", "topic"):  # a live topic's spec too: "spec" then shows it to edit (timeout=, …)
            self.spec_edit.setText(name)
        elif chosen == "camera":
            self.camera_number.setValue(int(name.partition(":")[2] or 0))

    def set_waiting(self, spec: str) -> None:
        """A spec of several kinds waits for the pipeline to get a kind."""
        self.name_label.setText(f" {spec} (waiting for a pipeline) ")
        self.name_label.setToolTip(f"{spec} is a source of several data kinds; the pipeline's kind decides which")

    @staticmethod
    def _rates_text(shown_fps: float, processing_ms: float, dropped: int, received: int | None = None,
                    stopped: str = "") -> str:
        of = f" of {received} received" if received is not None else ""
        shown = f"{stopped}: 0 frames/s shown" if stopped else f"{shown_fps:5.1f} frames/s shown"
        return f" {shown} · {processing_ms:5.1f} ms processing · {dropped} dropped{of} "

    def set_stopped(self, stopped: str) -> None:
        """Frames stopped coming (``stopped``: "paused", "ended"); "" when they come again (the next frame's
        rates follow). The label never goes on showing the rate of a second long past."""
        if self._last is None or stopped == self._stopped:
            return
        processing_ms, dropped, live = self._last
        self.set_rates(0.0, processing_ms, dropped, live, stopped)

    def set_rates(self, shown_fps: float, processing_ms: float, dropped: int,
                  live: tuple[int, int] | None = None, stopped: str = "") -> None:
        """The rates of the frames on screen; ``dropped`` were processed but replaced before the window showed
        them. ``live`` is a live topic's (received, dropped): its messages, and those a newer one replaced
        before the pipeline took them; both kinds of drop are counted, out of what the topic delivered.
        ``stopped`` ("paused", "ended") replaces the frames-shown rate: no frames come, whatever the last
        second's rate was."""
        self._last = (processing_ms, dropped, live)
        self._stopped = stopped
        if live is None:
            self.fps_label.setText(self._rates_text(shown_fps, processing_ms, dropped, stopped=stopped))
            self.fps_label.setToolTip("")
            return
        received, dropped_by_topic = live
        self.fps_label.setText(self._rates_text(shown_fps, processing_ms, dropped + dropped_by_topic, received,
                                                stopped))
        self.fps_label.setToolTip(f"{received} messages received from the topic; {dropped_by_topic} replaced by a "
                                  f"newer one before the pipeline took them (the newest frame wins), {dropped} "
                                  "processed but replaced before they were shown")
