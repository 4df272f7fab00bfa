"""DefinitionGUI: the window in which a user tunes a pipeline live and saves its parameter file.

It wires the pieces, each in a file of its own: the processing worker (off the GUI thread), the stage
views or the cloud view (for data kinds whose views show points), the panel column, the source bar, the File
and Pipeline menus. Everything kind-specific goes through the pipeline's ``Kind``: the window names no kind.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from PySide6.QtCore import QByteArray, QSettings, QSize, Qt, Signal
from PySide6.QtGui import QAction, QActionGroup, QCloseEvent, QKeySequence, QShowEvent
from PySide6.QtWidgets import (
    QDockWidget,
    QInputDialog,
    QLabel,
    QMainWindow,
    QMessageBox,
    QScrollArea,
    QToolBar,
)

from objrec_core import (
    FrameSource,
    Kind,
    RecognitionSystem,
    Rect,
    SelectionResult,
    SourceError,
    StageResults,
    UnknownModuleError,
    get_kind,
    open_source,
    source_kinds,
)

from .changes import ChangeTracker
from .export_script import export_dialog
from .eyedropper import Eyedropper
from .kind_guard import KindGuardedDirector
from .label_mode import LabelMode
from .live_topic_dialog import LiveTopicDialog
from .log_messages import LogToMessages
from .message_area import MessageArea, detector_reasons, is_file_error, selection_report
from .panel_column import PanelColumn
from .parameter_files import ParameterFiles
from .pipeline_menu import PipelineMenu
from .quality_strip import QualityStrip
from .recent_files import RecentFiles
from .seek_bar import SeekBar
from .selection_target import SelectionTarget, select_in
from .source_bar import ENDED_HERE, FrameRate, SourceBar, ended_message
from .stage_views import MODES, StageViews, stage_images
from .status_line import MessageBar
from .topic_chooser import with_topic
from .undo import UndoRecorder
from .view3d import View3D, prepare_scene
from .window_fit import PageStack, fit_to_screen
from .worker import ProcessingWorker, Shown

log = logging.getLogger(__name__)

#: Called with each area the user selects and the results of the frame it was drawn on.
SelectionCallback = Callable[[Rect, StageResults], None]


@dataclass
class Prepared:
    """What the worker thread made of a result for display, and the data kind it was made for."""

    kind: Kind
    content: Any


ABOUT = """<h3>objrec-define</h3>
<p>Tune a recognition pipeline on live data and save it as a parameter file that <code>objrec-detect</code>
runs unchanged, headless.</p>
<ul>
<li><b>Parameters</b> (right): one panel per module, in pipeline order. Every change applies at once.</li>
<li><b>Views</b> (centre): the original frame with the detections, each filter's output and each detector's
debug view, as tabs or a grid (View menu). Hover for a pixel's coordinates, BGR and HSV values; drag a
rectangle to give a target to the detectors (the feature detector learns it). Pipelines on point clouds
show the cloud: drag to rotate, right drag to pan, wheel to zoom, double click to reset.</li>
<li><b>Source</b> (top): the demo scene, a camera, a file, a folder or any source spec; pause, step,
frames per second.</li>
<li><b>Pipeline</b> menu: add, remove and reorder modules, including your own registered filters.</li>
<li><b>File</b> menu: open and save parameter files, and label files.</li>
<li><b>Tools</b> menu: <i>Label frames</i> (mark the objects of some frames: the <b>Quality</b> strip then shows
precision, recall and F1 of the current parameters over them, after every change) and <i>Tune</i> (search the
parameters that score best on the labelled frames).</li>
</ul>"""


def default_settings() -> QSettings:
    return QSettings("objrec", "objrec-define")


def live_counts(source: FrameSource | None) -> tuple[int, int] | None:
    """A live topic's (received, dropped) messages (objrec_ros.live.source.LiveSource counts them), None for
    any other source: read from the GUI thread, they are two counters, never a read of the source itself."""
    received, dropped = getattr(source, "received", None), getattr(source, "dropped", None)
    return (received, dropped) if isinstance(received, int) and isinstance(dropped, int) else None


#: The message dock's height on a first run, in pixels: the detector line and about four messages.
MESSAGES_HEIGHT = 130


class DefinitionGUI(QMainWindow):
    """The definition window for one RecognitionSystem (the object is kept; File>Open may replace its
    modules). ``source`` is a spec (``demo``, ``camera:0``, a path) or an open FrameSource. A spec that
    several data kinds read (``demo``) waits, while the pipeline has no kind, until it gets one.

    ``frameShown`` is emitted after each frame is put on screen, with the worker's ``Shown`` record.
    """

    frameShown = Signal(object)  # noqa: N815 - Qt's signal naming

    def __init__(
        self,
        system: RecognitionSystem | None = None,
        *,
        source: str | FrameSource | None = "demo",
        settings: QSettings | None = None,
        fps_limit: float | None = 30.0,
        view_mode: str | None = None,
        paused: bool = False,
        first_frame: bool = False,
    ) -> None:
        super().__init__()
        #: Whether a source opened while paused shows its first frame at once (a step), rather than waiting
        #: for Step or Play. Always for sources the user opens; for the one opened here, ``first_frame``
        #: (objrec-define --paused: paused on the first frame).
        self.first_frame_when_paused = first_frame
        self._first_frame_wanted = False
        #: The worker's count of processed frames when Loop last restarted a failing source.
        self._restarted_at = -1
        self.system = system if system is not None else RecognitionSystem()
        self.settings = settings if settings is not None else default_settings()
        self.director = KindGuardedDirector(self.system)  # a frame of another kind never reaches the pipeline
        self.worker = ProcessingWorker(self.director, fps_limit=fps_limit, prepare=self._prepare)
        self.selection_callbacks: list[SelectionCallback] = [self.give_selection_to_detectors]
        self.frame_rate = FrameRate()
        #: The data kind of the source open (or being opened), where known.
        self._source_kind: str | None = None
        #: A spec of several kinds, opened once the pipeline has a kind.
        self._waiting_spec: str | None = None
        #: The worker's count of frames it dropped when the source on screen opened.
        self._dropped_before = 0
        #: The last File > Open topic dialog (None before the first).
        self.topic_dialog: LiveTopicDialog | None = None
        self._kind_missing_reported = False
        self._last_results: StageResults | None = None
        #: The parameter generation of the frame on screen (compare with ``worker.generation``).
        self.last_shown_generation = -1
        self.files = ParameterFiles(self.system, self.settings, self, exclusive=self.worker.exclusive)
        # Part A: undo steps from the Change events (undo.py); unsaved-changes questions, opened values and the
        # description (changes.py). Made before the panels, which offer the opened values.
        self.undo = UndoRecorder(self.system, self)
        self.changes = ChangeTracker(self.system, self.undo.stack, self, self.files.save)
        self.files.guard = self.changes.may_lose_changes
        self.files.before_write = lambda: self.changes.before_save(shipped=self.files.origin is not None)

        self.stage_views = StageViews(view_mode or str(self.settings.value("view/mode", "tabs")))
        self.view3d = View3D()
        self.central = PageStack()  # sized to the page on screen: the 3D page never widens a 2D window
        self.central.addWidget(self.stage_views)
        self.central.addWidget(self.view3d)
        self.setCentralWidget(self.central)

        self.panels = PanelColumn(self.system)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(self.panels)
        scroll.setMinimumWidth(360)
        self.panel_dock = QDockWidget("Parameters", self)
        self.panel_dock.setObjectName("parameters_dock")
        self.panel_dock.setWidget(scroll)
        self.panel_dock.setFeatures(QDockWidget.DockWidgetFeature.DockWidgetMovable
                                    | QDockWidget.DockWidgetFeature.DockWidgetFloatable)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.panel_dock)

        self.source_bar = SourceBar(self.files.last_folder, self, kind=lambda: self.system.kind)
        self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.source_bar)
        # Part B: moving through recordings (seek_bar.py) and every message kept whole (message_area.py).
        self.seek_bar = SeekBar(self)
        self.addToolBarBreak(Qt.ToolBarArea.TopToolBarArea)
        self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.seek_bar)
        self.message_area = MessageArea(self)
        self.addDockWidget(Qt.DockWidgetArea.BottomDockWidgetArea, self.message_area)
        # A folder's unreadable files, logged by the source, reach the message area too.
        self.source_warnings = LogToMessages()
        self.source_warnings.logged.connect(self._source_warning)
        self.source_warnings.attach()

        self.hover_label = QLabel()
        self.path_label = QLabel()
        # Fixed widths: a long pixel readout or a deep path must not widen the window (the path is elided).
        self.hover_label.setFixedWidth(480)
        self.path_label.setFixedWidth(280)
        self.setStatusBar(MessageBar(self))  # messages cut at a word, left of the read-out
        self.statusBar().addPermanentWidget(self.hover_label)
        self.statusBar().addPermanentWidget(self.path_label)
        self.hover_label.hide()  # shown while the mouse is over a picture: the messages have its room otherwise

        self.pipeline_menu = PipelineMenu(self.system, self)
        # A selection goes to one detector, the one whose panel was last used (or chosen).
        self.selection_target = SelectionTarget(self.system, self.panels, self.ask_choice, self)
        self.eyedropper = Eyedropper(self.system, lambda text, error: self.show_message(text, error=error), self)
        # A row of their own: beside the seek bar of a recording they ran off a 1280 px screen.
        self.addToolBarBreak(Qt.ToolBarArea.TopToolBarArea)
        self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.eyedropper.toolbar)
        # Labels drawn on the frames (label_mode.py) and their figures, live (quality_strip.py).
        self._source_spec: str | None = None
        self.labels = LabelMode(self)
        self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.labels.toolbar)
        self.quality = QualityStrip(self.system, self.labels.store, self._data_kind, self._reopen_source, self)
        self.quality_bar = QToolBar("Quality", self)
        self.quality_bar.setObjectName("quality_toolbar")
        self.quality_bar.addWidget(self.quality)
        self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.quality_bar)
        self._build_menus()
        self._connect()
        self._update_title()
        self._restore_layout()
        self._follow_kind()
        if paused:
            self.set_paused(True)
        if isinstance(source, FrameSource):
            self._source_kind = source.kind or self.system.kind
            self.worker.set_source(source, self._source_kind)
        elif source:
            self.open_source(source)
        if isinstance(source, FrameSource):
            self._first_frame_wanted = self.first_frame_when_paused
        self.first_frame_when_paused = True
        self.worker.start()

    # -- construction ---------------------------------------------------------------------------------------
    def _build_menus(self) -> None:
        bar = self.menuBar()
        file_menu = bar.addMenu("&File")
        self.open_action = self._action(file_menu, "&Open…", QKeySequence.StandardKey.Open, self.files.open)
        self.recent = RecentFiles(self.settings, self.files.open, self)
        file_menu.addMenu(self.recent.menu)
        self.open_topic_action = self._action(file_menu, "Open &topic…", QKeySequence("Ctrl+T"), self.open_topic)
        self.open_topic_action.setToolTip("Tune on a live ROS 1 or ROS 2 topic: list what is published, open one")
        self.save_action = self._action(file_menu, "&Save", QKeySequence.StandardKey.Save, self.files.save)
        self.save_as_action = self._action(file_menu, "Save &As…", QKeySequence("Ctrl+Shift+S"), self.files.save_as)
        file_menu.addSeparator()
        self.export_action = self._action(file_menu, "&Export as Python script…", None, self.export_script)
        file_menu.addSeparator()
        file_menu.addActions([self.labels.open_action, self.labels.save_action])
        file_menu.addSeparator()
        self.quit_action = self._action(file_menu, "&Quit", QKeySequence.StandardKey.Quit, self.close)
        self.open_action.setShortcut(QKeySequence("Ctrl+O"))
        self.save_action.setShortcut(QKeySequence("Ctrl+S"))
        self.quit_action.setShortcut(QKeySequence("Ctrl+Q"))

        edit_menu = bar.addMenu("&Edit")
        self.undo_action = self.undo.stack.createUndoAction(self, "&Undo")
        self.undo_action.setShortcut(QKeySequence("Ctrl+Z"))
        self.redo_action = self.undo.stack.createRedoAction(self, "&Redo")
        self.redo_action.setShortcut(QKeySequence("Ctrl+Shift+Z"))
        edit_menu.addActions([self.undo_action, self.redo_action])
        edit_menu.addSeparator()
        self.description_action = self._action(edit_menu, "&Description…", None, self.changes.edit_description)

        view_menu = bar.addMenu("&View")
        group = QActionGroup(self)
        self.mode_actions: dict[str, QAction] = {}
        for mode in MODES:
            action = QAction(f"Stages as {mode}", self, checkable=True)
            action.setChecked(mode == self.stage_views.mode)
            action.triggered.connect(lambda _=False, m=mode: self.set_view_mode(m))
            group.addAction(action)
            view_menu.addAction(action)
            self.mode_actions[mode] = action
        view_menu.addSeparator()
        view_menu.addAction(self.panel_dock.toggleViewAction())
        view_menu.addAction(self.source_bar.toggleViewAction())
        view_menu.addAction(self.seek_bar.toggleViewAction())
        view_menu.addAction(self.eyedropper.toolbar.toggleViewAction())
        view_menu.addAction(self.message_area.toggleViewAction())

        bar.addMenu(self.pipeline_menu)
        tools_menu = bar.addMenu("&Tools")
        tools_menu.addAction(self.labels.action)
        self.tune_action = self._action(tools_menu, "&Tune…", None, self.open_tune_dialog)
        self.tune_action.setToolTip("Search the parameters that score best on the labelled frames (Optuna)")
        view_menu.addAction(self.labels.toolbar.toggleViewAction())
        view_menu.addAction(self.quality_bar.toggleViewAction())
        help_menu = bar.addMenu("&Help")
        self.about_action = self._action(help_menu, "&About", None, self.show_about)

    def _action(self, menu: Any, text: str, shortcut: Any, slot: Callable[[], Any]) -> QAction:
        action = QAction(text, self)
        if shortcut is not None:
            action.setShortcut(shortcut)
        action.triggered.connect(lambda _=False: slot())
        menu.addAction(action)
        return action

    def _connect(self) -> None:
        self.worker.resultReady.connect(self._show_newest)
        self.worker.failed.connect(self._worker_failed)
        self.worker.sourceOpened.connect(self._source_opened)
        self.worker.sourceEnded.connect(self._source_ended)
        self.worker.pausedChanged.connect(self.source_bar.set_paused)
        self.worker.pausedChanged.connect(lambda paused: paused and self._frames_stopped("paused"))
        self.worker.callDone.connect(lambda done, result: done(result))
        self.source_bar.sourceRequested.connect(self.open_source)
        self.source_bar.pauseToggled.connect(self.set_paused)
        self.source_bar.stepRequested.connect(self.worker.step)
        self.source_bar.restartRequested.connect(self.restart_source)
        self.source_bar.topicRequested.connect(self.open_topic)
        self.source_bar.folderUsed.connect(self.files.remember_folder)
        self.files.message.connect(self.show_message)
        self.files.message.connect(lambda text: is_file_error(text) and self.message_area.show_dialog(text))
        self.panels.pipeline_changed.connect(lambda: self.message_area.check_pipeline(self.system))
        self.files.opened.connect(lambda _path: self.message_area.check_pipeline(self.system))
        self.worker.positionChanged.connect(self.seek_bar.set_position)
        self.worker.sourceFacts.connect(self.seek_bar.set_source)
        self.seek_bar.seekRequested.connect(self.worker.seek)
        self.seek_bar.loopToggled.connect(lambda on: setattr(self.worker, "loop", on))
        self.seek_bar.stillRateChanged.connect(lambda rate: setattr(self.worker, "still_rate", rate))
        self.files.pathChanged.connect(lambda _path: self._update_title())
        self.files.opened.connect(lambda _path: (self.undo.reset(), self.changes.opened()))
        self.files.saved.connect(lambda _path: self.undo.stack.setClean())
        self.files.opened.connect(self.recent.add)
        self.files.saved.connect(self.recent.add)
        self.changes.modifiedChanged.connect(lambda _modified: self._update_title())
        self.files.opened.connect(lambda _path: self._follow_kind())
        self.panels.error.connect(lambda text: self.show_message(text, error=True))
        self.panels.pipeline_changed.connect(self._follow_kind)
        self.pipeline_menu.message.connect(self.show_message)
        self.stage_views.areaSelected.connect(self.hand_selection)
        self.stage_views.hovered.connect(self._show_pixel)

    # -- sources ------------------------------------------------------------------------------------------
    def open_source(self, spec: str, why: str = "") -> None:
        """Open a source for the pipeline's kind of data (in the worker thread). With no kind yet, the kind
        whose source reads the spec; a spec of several kinds (``demo``) waits for the pipeline to get one.
        ``why`` starts the status message. A recording of several topics asks which one to play."""
        chosen = with_topic(spec, self.ask_choice, self.system.kind)
        if chosen is None:
            self.show_message(f"{spec} not opened: no topic chosen")
            return
        spec = chosen
        kind = self.system.kind
        if kind is None:
            try:
                kinds = source_kinds(spec)
            except SourceError as exc:
                self.show_message(str(exc), error=True)
                return
            if len(kinds) > 1:
                self._waiting_spec = spec
                self.source_bar.set_waiting(spec)
                what = " and ".join(self._kind_title(k) for k in kinds)
                self.show_message(f"{spec} is a source of {what}: add a module or open a parameter file to choose")
                self.stage_views.set_placeholder(
                    f"{spec} is a source of {what}.\nThe pipeline's data kind decides which: add a module from the "
                    f"Pipeline menu or open a parameter file (File > Open), and {spec} opens for it.")
                return
            kind = kinds[0] if kinds else None  # none: opening it says what is wrong
        self._waiting_spec = None
        self._source_kind = kind
        self.show_message(f"{why}: opening {spec}…" if why else f"Opening {spec}…")
        self.view3d.set_busy(f"opening {spec}…")  # a large cloud can take seconds: say so, not a black view
        self._source_spec = spec
        self._first_frame_wanted = self.first_frame_when_paused
        self.worker.open_source(spec, kind)

    def open_topic(self) -> LiveTopicDialog:
        """File > Open topic…: a dialog listing the live topics (live_topic_dialog.py); the chosen one opens as
        the source. Window-modal but not blocking (``open``, not ``exec``): the source on screen keeps playing
        while the listing waits for a master. The dialog is returned (and kept as ``topic_dialog``)."""
        dialog = LiveTopicDialog(self.system.kind, self)
        dialog.message.connect(self.show_message)
        dialog.accepted.connect(lambda: self.open_source(dialog.spec))
        dialog.finished.connect(lambda _result: dialog.deleteLater())
        self.topic_dialog = dialog
        dialog.open()
        return dialog

    def _reopen_source(self) -> FrameSource | None:
        """A fresh opening of the source on screen (any thread; the quality strip reads labelled frames from
        it), None when it was given as an object or cannot be opened again."""
        spec, kind = self._source_spec, self.worker.source_kind
        if spec is None:
            return None
        try:
            return open_source(spec, kind)
        except SourceError:
            return None

    def open_tune_dialog(self) -> Any:
        """Tools > Tune…: the tuning dialog (tune_dialog.py) over the labelled frames; returned (and kept as
        ``tune_dialog``)."""
        from .tune_dialog import TuneDialog  # Optuna is an extra: imported when asked for

        dialog = TuneDialog(self)
        self.tune_dialog = dialog
        dialog.open()
        return dialog

    def ask_choice(self, title: str, labels: list[str]) -> str | None:
        """One of ``labels``, chosen by the user in a dialog; None when cancelled."""
        dialog = QInputDialog(self)
        dialog.setWindowTitle("objrec-define")
        dialog.setLabelText(title)
        dialog.setComboBoxItems(labels)
        dialog.setComboBoxEditable(False)
        dialog.setOkButtonText("&OK")  # mnemonics in every dialog
        dialog.setCancelButtonText("&Cancel")
        ok = dialog.exec() == QInputDialog.DialogCode.Accepted
        label = dialog.textValue()
        dialog.deleteLater()
        return label if ok else None

    @staticmethod
    def _kind_title(name: str) -> str:
        try:
            return f"{get_kind(name).title} ({name})"
        except UnknownModuleError:
            return name

    def _kind(self, name: str | None) -> Kind | None:
        """The registered kind called ``name`` (None, or reported, when there is none)."""
        if name is None:
            return None
        try:
            return get_kind(name)
        except UnknownModuleError as exc:
            self.show_message(str(exc), error=True)
            return None

    def set_paused(self, paused: bool) -> None:
        self.worker.set_paused(paused)
        self.source_bar.set_paused(paused)

    def restart_source(self) -> None:
        """Play the source on screen again from its first frame (the source bar's Restart, once it ended): a
        recording goes back to frame 0, any other source given by its spec (a camera, a live topic) is opened
        again. It plays, not paused: Restart is a Play from the start."""
        source = self.worker.source
        if source is None:
            return
        facts = self.worker.facts
        if facts is not None and facts.name == source.name and facts.seekable:
            self.worker.seek(0)
        elif self._source_spec is not None:
            self.open_source(self._source_spec)
        else:
            self.show_message(f"{source.name} cannot be played again: open a source from the source bar",
                              error=True)
            return
        self.set_paused(False)
        self.show_message(f"{source.name}: playing again from the start")

    def _source_opened(self, name: str, kind: str) -> None:
        if kind:
            self._source_kind = kind
        self._dropped_before = self.worker.dropped
        self.source_bar.set_source_name(name)
        self.show_message(f"Source: {name}")
        self.stage_views.clear()
        self.view3d.clear()
        if self.worker.paused:
            if self._first_frame_wanted:
                self.worker.step()  # paused on the first frame, not on an empty page
            else:
                self.stage_views.set_placeholder(f"{name} is open, paused before its first frame: Step or Play "
                                                 "shows it.")
                self.view3d.set_busy(f"{name}: paused before the first frame (Step or Play)")
        self._first_frame_wanted = False

    def _source_ended(self, name: str) -> None:
        self.source_bar.set_source_name(name, ended=True)
        self.seek_bar.source_ended()
        self._frames_stopped("ended")
        self.show_message(ended_message(name))

    def _frames_stopped(self, why: str) -> None:
        """No more frames come (paused, ended): the frames-shown rate says so instead of going stale."""
        self.frame_rate.reset()
        self.source_bar.set_stopped(why)

    def _show_pixel(self, text: str) -> None:
        """The pixel read-out: shown while the mouse is over a picture, hidden (its room the messages') when
        it leaves."""
        self.hover_label.setText(text)
        self.hover_label.setVisible(bool(text))

    def _source_warning(self, text: str) -> None:
        """A source's warning (a folder's file skipped): kept in the message area and shown in the status bar;
        the log has it already."""
        self.message_area.add(text, True)
        self.statusBar().showMessage(text, 30000)

    def _worker_failed(self, text: str) -> None:
        """A source or a module failed. A source that cannot decode a frame (a truncated video) ends there:
        the seek bar offers only the frames before it, its thumb goes back to the frame on screen, and with
        Loop on the recording starts again (once per frame read: a source whose first frame fails stops)."""
        self.show_message(text, error=True)
        if text.startswith("processing frame"):  # a module's failure: the source plays on
            return
        ended, sought = self.worker.ended, self.seek_bar.pending
        self.seek_bar.source_failed(text, ended)
        shown = self.seek_bar.shown
        if not ended:
            return
        if self.seek_bar.length is not None and shown is not None:
            if sought is not None and sought != shown:
                self.worker.seek(shown)  # a seek that failed: back to the frame on screen, Step and Play go on
                return
            if self.worker.loop and self._restarted_at != self.worker.processed:
                self._restarted_at = self.worker.processed
                self.worker.seek(0)
                return
        # The source stops here, as at its end: the bars say so, not the rate of the last second's frames.
        source = self.worker.source
        name = source.name if source is not None else ""
        self.source_bar.set_source_name(name, ended=True)
        self._frames_stopped("ended")
        if source is not None:  # the error stays the message; the status bar adds where that leaves the source
            self.statusBar().showMessage(f"{ENDED_HERE}: {text}", 30000)

    def _follow_kind(self) -> None:
        """Show the page for the pipeline's kind; a spec waiting for a kind opens now, and a pipeline whose
        kind changed gets that kind's demo source."""
        self._update_title()
        self.eyedropper.follow_pipeline()
        kind = self._kind(self.system.kind)
        if kind is None:
            return
        self._kind_missing_reported = False
        self.central.setCurrentWidget(self.view3d if kind.has_points else self.stage_views)
        waiting, self._waiting_spec = self._waiting_spec, None
        if waiting is not None:
            try:
                readable = kind.name in source_kinds(waiting)
            except SourceError:
                readable = False
            if readable:
                self.open_source(waiting)
            else:
                self.open_source(kind.demo_spec, f"no source of {kind.title} reads {waiting}")
        elif self._source_kind is not None and kind.name != self._source_kind:
            self.open_source(kind.demo_spec, f"the pipeline now works on {kind.title}")

    # -- results ------------------------------------------------------------------------------------------
    def _data_kind(self) -> Kind | None:
        """The kind of the frames processed: the pipeline's, else the source's (any thread)."""
        name = self.system.kind or self.worker.source_kind
        if name is None:
            return None
        try:
            return get_kind(name)
        except UnknownModuleError:
            return None

    def _prepare(self, results: StageResults) -> Prepared | None:
        """Worker thread: draw the stage pictures, or merge the point layers, before the GUI sees them."""
        kind = self._data_kind()
        if kind is None:
            return None
        if kind.has_points:
            return Prepared(kind, prepare_scene(results, kind))
        return Prepared(kind, stage_images(results, kind, self.stage_views.display_sizes))

    def _show_newest(self) -> None:
        shown = self.worker.take()
        if shown is None:
            return
        self.show_results(shown)

    def show_results(self, shown: Shown) -> None:
        results = shown.results
        prepared = shown.prepared if isinstance(shown.prepared, Prepared) else None
        kind = prepared.kind if prepared is not None else self._data_kind()
        if kind is None:
            if not self._kind_missing_reported:
                self._kind_missing_reported = True
                self.show_message("the frames' data kind is not known yet: add a module from the Pipeline menu "
                                  "or open a parameter file", error=True)
            return
        content = prepared.content if prepared is not None else None
        if kind.has_points:
            self.central.setCurrentWidget(self.view3d)
            self.view3d.show_results(results, kind, content, preview_step=shown.preview_step)
        else:
            self.central.setCurrentWidget(self.stage_views)
            self.stage_views.show_results(results, kind, content)
        self._last_results = results
        self.last_shown_generation = shown.generation
        self.frame_rate.tick(time.perf_counter())
        live = live_counts(self.worker.source)
        dropped = self.worker.dropped - (self._dropped_before if live is not None else 0)  # a topic's: its own
        stopped = "paused" if self.worker.paused else "ended" if self.worker.ended else ""
        if self.source_bar.ended != self.worker.ended:  # sought or restarted after its end: it plays again
            self.source_bar.set_ended(self.worker.ended)
        if stopped:
            self.frame_rate.reset()
        self.source_bar.set_rates(self.frame_rate.rate(), results.seconds * 1000, dropped, live, stopped)
        self.message_area.show_detectors(detector_reasons(results))
        self.panels.show_results(results)
        self.frameShown.emit(shown)

    @property
    def last_results(self) -> StageResults | None:
        """The results of the frame on screen."""
        return self._last_results

    # -- area selection -------------------------------------------------------------------------------------
    def add_selection_callback(self, callback: SelectionCallback) -> None:
        """Also hand every selection to ``callback(rect, results)`` (in the GUI thread)."""
        self.selection_callbacks.append(callback)

    def hand_selection(self, rect: Rect, results: StageResults | None) -> None:
        results = results if results is not None else self._last_results
        if results is None:
            self.show_message("no frame on screen yet to select in", error=True)
            return
        if self.eyedropper.wants(self.stage_views.selection_modifiers):
            self.eyedropper.pick(rect, results)
            return
        for callback in list(self.selection_callbacks):
            try:
                callback(rect, results)
            except Exception as exc:
                log.exception("selection callback %r failed", callback)
                self.show_message(f"selection failed: {exc}", error=True)

    def give_selection_to_detectors(self, rect: Rect, results: StageResults) -> None:
        """The default callback: the chosen detector (selection_target.py: the last panel used, the only one
        that takes selections, or the user's choice) gets the rectangle with the frame it saw when the user
        drew it (its own input in that frame's results), in the worker thread, between two frames: one change,
        one undo step."""
        chosen = self.selection_target.choose()
        if chosen is None:
            self.show_message("selection not used: no detector chosen")
            return

        def select() -> SelectionResult:
            outcome = SelectionResult()
            for detector in chosen:
                one = select_in(detector, rect, results)
                outcome.accepted += one.accepted
                outcome.refused.update(one.refused)
            return outcome

        self.worker.call(select, lambda outcome: self._selection_done(rect, outcome))

    def _selection_done(self, rect: Rect, outcome: SelectionResult | Exception) -> None:
        where = f"{rect.width}×{rect.height} at ({rect.x}, {rect.y})"
        if isinstance(outcome, Exception):
            self.show_message(f"selection {where} failed: {outcome}", error=True)
            return
        self.show_message(*selection_report(self.system, rect, outcome))
        self.worker.reprocess()

    # -- window ---------------------------------------------------------------------------------------------
    def show_message(self, text: str, error: bool = False) -> None:
        """Status bar: reports stay 10 s, errors 30 s (or until the next message); the message area keeps
        the last ones whole."""
        self.message_area.add(text, error or is_file_error(text))
        if error:
            log.warning("%s", text)
        self.statusBar().showMessage(text, 30000 if error else 10000)

    def set_view_mode(self, mode: str) -> None:
        self.stage_views.set_mode(mode)
        self.mode_actions[mode].setChecked(True)
        self.settings.setValue("view/mode", mode)

    def export_script(self, path: str | None = None) -> bool:
        """File > Export as Python script (export_script.py); ``path`` None asks where."""
        return export_dialog(self, self.system, self.files, self.show_message, path)

    def show_about(self) -> None:
        QMessageBox.about(self, "About objrec-define", ABOUT)

    def _update_title(self) -> None:
        path = self.files.path
        name = path.name if path else "untitled"
        if path is None and self.files.origin:
            name += f", from the shipped {self.files.origin}"
        mark = "*" if self.changes.modified else ""  # the modified mark: unsaved changes
        self.setWindowTitle(f"objrec-define — {name}{mark} ({self.system.kind or 'empty'} pipeline)")
        text = str(path) if path else "not saved yet"
        metrics = self.path_label.fontMetrics()
        self.path_label.setText(metrics.elidedText(text, Qt.TextElideMode.ElideMiddle, self.path_label.width() - 8))
        self.path_label.setToolTip(text)

    def _restore_layout(self) -> None:
        geometry = self.settings.value("window/geometry")
        state = self.settings.value("window/state")
        if isinstance(geometry, QByteArray | bytes):
            self.restoreGeometry(QByteArray(geometry))
        else:
            self.resize(1280, 800)
        self._layout_size: QSize | None = self.size()  # fitted to the screen when first shown, unless resized
        if isinstance(state, QByteArray | bytes):
            self.restoreState(QByteArray(state))
            hidden_for_stream = str(self.settings.value("window/seek_bar_hidden_for_stream", "false")).lower()
            self.seek_bar.hidden_for_stream = hidden_for_stream == "true" and not self.seek_bar.isVisibleTo(self)
        else:  # a first run: the messages take a strip at the bottom, the views the room
            self.resizeDocks([self.message_area], [MESSAGES_HEIGHT], Qt.Orientation.Vertical)

    def showEvent(self, event: QShowEvent) -> None:  # noqa: N802 - Qt override
        """A window restored from a larger screen comes back within this one (window_fit.py)."""
        super().showEvent(event)
        restored, self._layout_size = self._layout_size, None
        if restored == self.size() and not self.isMaximized() and not self.isFullScreen():
            fit_to_screen(self)

    def save_layout(self) -> None:
        self.settings.setValue("window/geometry", self.saveGeometry())
        self.settings.setValue("window/state", self.saveState())
        # hidden for the stream on screen, not by the user: the next run shows it again for a recording
        self.settings.setValue("window/seek_bar_hidden_for_stream", self.seek_bar.hidden_for_stream)
        self.settings.setValue("view/mode", self.stage_views.mode)
        self.settings.sync()

    def closeEvent(self, event: QCloseEvent) -> None:  # noqa: N802 - Qt override
        # Cancel (or a failed save) keeps the window; a window never shown has no one to ask.
        if self.isVisible() and not (self.changes.may_lose_changes("quitting")
                                     and self.labels.may_lose_labels("quitting")):
            event.ignore()
            return
        self.save_layout()
        self.worker.stop()
        self.quality.detach()
        self.panels.detach()
        self.selection_target.detach()
        self.source_warnings.detach()
        self.changes.detach()  # the undo stack clears itself when destroyed: no title update then
        self.undo.detach()  # a closed window leaves no observer on the modules (a caller may keep the system)
        super().closeEvent(event)

