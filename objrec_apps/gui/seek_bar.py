"""The seek bar: where in a recording the frame on screen is, and a way to go anywhere in it.

A slider over the frames with a counter ("frame 12 / 300"), the file name for folders (each frame of a folder
is a file of its own), loop on/off and the rate of sources that have none of their own (a folder of images
would otherwise run through in seconds). It is enabled only for seekable sources of known length (videos,
folders, cloud files, bags). A stream (a live topic, a camera, the endless demo: no length and no seeking) has
nothing to seek in, not even an end: the bar is hidden for it, not left greyed out taking a row, and shown
again for the next recording (unless the user hid it from the View menu).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QCheckBox, QDoubleSpinBox, QLabel, QSlider, QToolBar, QWidget

from objrec_core import FrameSource


@dataclass(frozen=True)
class SourceFacts:
    """What the seek bar needs of a source, read once in the processing thread: a bag or video must not be
    read from the GUI thread while the worker reads (or closes) it."""

    name: str
    length: int | None
    seekable: bool
    rate: float | None

    @classmethod
    def of(cls, source: FrameSource) -> SourceFacts:
        return cls(source.name, source.length, source.seekable, source.rate)

    @property
    def is_stream(self) -> bool:
        """Frames that only come and go (a live topic, a camera, the endless demo): no length, no seeking."""
        return self.length is None and not self.seekable


class SeekBar(QToolBar):
    """Emits ``seekRequested(index)`` when the user moves the slider (on release, so a video is not decoded
    at every pixel of a drag), ``loopToggled(on)`` and ``stillRateChanged(frames_per_second)``."""

    seekRequested = Signal(int)  # noqa: N815 - Qt's signal naming
    loopToggled = Signal(bool)  # noqa: N815 - Qt's signal naming
    stillRateChanged = Signal(float)  # noqa: N815 - Qt's signal naming

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__("Position", parent)
        self.setObjectName("seek_bar")
        self.slider = QSlider(Qt.Orientation.Horizontal)
        self.slider.setObjectName("seek_slider")
        self.slider.setTracking(False)  # valueChanged on release or a click/key step, not during a drag
        self.slider.setMinimumWidth(300)
        self.slider.setToolTip("Go to a frame of the recording (drag and release, click, or arrow keys)")
        self.slider.valueChanged.connect(self.seekRequested)
        self.addWidget(self.slider)
        self.counter = QLabel()
        self.counter.setObjectName("frame_counter")
        self.counter.setMinimumWidth(self.counter.fontMetrics().horizontalAdvance(" frame 99999 / 99999 ") + 4)
        self.addWidget(self.counter)
        self.file_label = QLabel()
        self.file_label.setObjectName("frame_file")
        self.file_label.setMinimumWidth(160)
        self.addWidget(self.file_label)
        self.addSeparator()
        self.loop_box = QCheckBox("Loop")
        self.loop_box.setToolTip("Start the recording again when it ends")
        self.loop_box.toggled.connect(self.loopToggled)
        self.addWidget(self.loop_box)
        self.rate_box = QDoubleSpinBox()
        self.rate_box.setRange(0.1, 120.0)
        self.rate_box.setDecimals(1)
        self.rate_box.setSingleStep(1.0)
        self.rate_box.setValue(5.0)
        self.rate_box.setSuffix(" frames/s")
        self.rate_box.setToolTip("Pace of sources without a rate of their own (a folder of images); videos and "
                                 "bags play at their recorded rate")
        self.rate_box.valueChanged.connect(self.stillRateChanged)
        self.rate_label = QLabel(" rate ")
        self.addWidget(self.rate_label)
        self.addWidget(self.rate_box)
        self.length: int | None = None
        self.source_name = ""
        #: Hidden by set_source for a stream (not by the user): shown again for the next recording.
        self.hidden_for_stream = False
        self.set_source(None)

    def set_source(self, source: SourceFacts | None) -> None:
        """Follow a newly opened source: a range for seekable ones of known length, disabled otherwise (hidden
        for a stream); the rate box only where the source has no rate of its own."""
        length = source.length if source is not None else None
        seekable = source is not None and source.seekable and length is not None and length > 0
        self.length = length if seekable else None
        self.source_name = source.name if source is not None else ""
        self.slider.blockSignals(True)
        self.slider.setRange(0, max(0, (length or 1) - 1) if seekable else 0)
        self.slider.setValue(0)
        self.slider.blockSignals(False)
        self.slider.setEnabled(seekable)
        self.loop_box.setEnabled(seekable)
        own_rate = source.rate if source is not None else None
        self.rate_box.setEnabled(source is not None and not own_rate and length is not None)
        self.rate_label.setText(f" {own_rate:.3g} frames/s (the source's own) " if own_rate else " rate ")
        self.counter.setText(" no recording to seek in " if not seekable else f" frame - / {length} ")
        self.file_label.setText("")
        self._follow_stream(source is not None and source.is_stream)

    def _follow_stream(self, stream: bool) -> None:
        """Hide the bar for a stream; show it again afterwards only if it was this that hid it, so a bar the
        user closed (View menu, or a layout restored so) stays closed."""
        parent = self.parentWidget()
        shown = self.isVisibleTo(parent) if parent is not None else not self.isHidden()
        if stream and shown:
            self.hidden_for_stream = True
            self.setVisible(False)
        elif not stream and self.hidden_for_stream:
            self.hidden_for_stream = False
            self.setVisible(True)

    def set_position(self, index: int, length: int, where: str) -> None:
        """The frame just read: its number (shown 1-based), the source's length (-1 unknown) and where it came
        from; a frame from a file other than the source itself (a folder's image) shows the file's name."""
        self.counter.setText(f" frame {index + 1} / {length} " if length >= 0 else f" frame {index + 1} ")
        if where and where != self.source_name:
            self.file_label.setText(f" {Path(where).name} ")
            self.file_label.setToolTip(where)
        else:
            self.file_label.setText("")
        if self.slider.isEnabled() and not self.slider.isSliderDown() and 0 <= index <= self.slider.maximum():
            self.slider.blockSignals(True)
            self.slider.setValue(index)
            self.slider.blockSignals(False)

    @property
    def counter_text(self) -> str:
        return self.counter.text().strip()
