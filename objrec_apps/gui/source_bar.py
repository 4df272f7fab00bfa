"""Source controls: choose the demo, a camera, a file or a folder; pause, resume, single step; fps."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from PySide6.QtCore import Signal
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QComboBox, QFileDialog, QLabel, QPushButton, QSpinBox, QToolBar, QWidget

KINDS = ("demo", "camera", "file", "folder")


class FrameRate:
    """Frames shown per second over the last second or so (a moving window, not a lifetime mean)."""

    def __init__(self, window: float = 1.0) -> None:
        self.window = window
        self._stamps: deque[float] = deque()

    def tick(self, now: float) -> None:
        self._stamps.append(now)
        while self._stamps and now - self._stamps[0] > self.window:
            self._stamps.popleft()

    def rate(self) -> float:
        if len(self._stamps) < 2:
            return 0.0
        span = self._stamps[-1] - self._stamps[0]
        return (len(self._stamps) - 1) / span if span > 0 else 0.0


class SourceBar(QToolBar):
    """Emits ``sourceRequested(spec)`` with a spec every kind plug-in accepts (``demo``, ``camera:N``,
    a path); the window opens it. ``last_folder`` gives where file dialogs start."""

    sourceRequested = Signal(str)  # noqa: N815 - Qt's signal naming
    pauseToggled = Signal(bool)  # noqa: N815 - Qt's signal naming
    stepRequested = Signal()  # noqa: N815 - Qt's signal naming
    folderUsed = Signal(str)  # noqa: N815 - Qt's signal naming

    def __init__(self, last_folder: Callable[[], str], parent: QWidget | None = None) -> None:
        super().__init__("Source", parent)
        self.setObjectName("source_bar")
        self.last_folder = last_folder
        self.addWidget(QLabel(" Source "))
        self.kind = QComboBox()
        self.kind.addItems(list(KINDS))
        self.kind.setToolTip("demo: the built-in synthetic scene; camera: a camera by number; file: an image, "
                             "video or cloud file; folder: a folder of images or clouds")
        self.kind.currentTextChanged.connect(self._kind_changed)
        self.addWidget(self.kind)
        self.camera_number = QSpinBox()
        self.camera_number.setRange(0, 63)
        self.camera_number.setPrefix("camera ")
        self.camera_action = self.addWidget(self.camera_number)
        self.camera_action.setVisible(False)
        self.open_button = QPushButton("Open")
        self.open_button.setToolTip("Open the chosen source")
        self.open_button.clicked.connect(self.request)
        self.addWidget(self.open_button)
        self.name_label = QLabel()
        self.name_label.setMinimumWidth(120)
        self.addWidget(self.name_label)
        self.addSeparator()
        self.pause_action = QAction("Pause", self)
        self.pause_action.setCheckable(True)
        self.pause_action.setShortcut(QKeySequence("Space"))
        self.pause_action.setToolTip("Pause or resume the source (Space); parameter changes still apply")
        self.pause_action.toggled.connect(self._pause_toggled)
        self.addAction(self.pause_action)
        self.step_action = QAction("Step", self)
        self.step_action.setShortcut(QKeySequence("Ctrl+Right"))
        self.step_action.setToolTip("Pause and process exactly one new frame (Ctrl+Right)")
        self.step_action.triggered.connect(self.stepRequested)
        self.addAction(self.step_action)
        self.addSeparator()
        self.fps_label = QLabel()
        sample = self._rates_text(999.9, 9999.9, 999999)
        self.fps_label.setMinimumWidth(self.fps_label.fontMetrics().horizontalAdvance(sample) + 8)
        self.addWidget(self.fps_label)

    def _kind_changed(self, kind: str) -> None:
        self.camera_action.setVisible(kind == "camera")
        self.open_button.setText("Open…" if kind in ("file", "folder") else "Open")

    def request(self) -> None:
        """Turn the chosen kind into a spec (asking for the path where needed) and emit it."""
        kind = self.kind.currentText()
        if kind == "demo":
            spec = "demo"
        elif kind == "camera":
            spec = f"camera:{self.camera_number.value()}"
        elif kind == "file":
            spec, _ = QFileDialog.getOpenFileName(
                self, "Open an image, video or cloud file", self.last_folder(),
                "Images, videos and clouds (*.png *.jpg *.jpeg *.bmp *.tif *.tiff *.ppm *.pgm *.webp *.avi *.mp4 "
                "*.mkv *.mov *.pcd *.ply);;All files (*)",
            )
        else:
            spec = QFileDialog.getExistingDirectory(self, "Open a folder of images or clouds", self.last_folder())
        if spec:
            if kind in ("file", "folder"):
                self.folderUsed.emit(spec)
            self.sourceRequested.emit(spec)

    def _pause_toggled(self, paused: bool) -> None:
        self.pause_action.setText("Resume" if paused else "Pause")
        self.pauseToggled.emit(paused)

    def set_paused(self, paused: bool) -> None:
        if self.pause_action.isChecked() != paused:
            self.pause_action.blockSignals(True)
            self.pause_action.setChecked(paused)
            self.pause_action.setText("Resume" if paused else "Pause")
            self.pause_action.blockSignals(False)

    def set_source_name(self, name: str, ended: bool = False) -> None:
        self.name_label.setText(f" {name} (ended) " if ended else f" {name} ")

    @staticmethod
    def _rates_text(shown_fps: float, processing_ms: float, dropped: int) -> str:
        return f" {shown_fps:5.1f} frames/s shown · {processing_ms:5.1f} ms processing · {dropped} dropped "

    def set_rates(self, shown_fps: float, processing_ms: float, dropped: int) -> None:
        self.fps_label.setText(self._rates_text(shown_fps, processing_ms, dropped))
