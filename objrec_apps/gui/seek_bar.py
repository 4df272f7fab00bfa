"""The seek bar: where in a recording the frame on screen is, and a way to go anywhere in it.

A slider over the frames with a counter ("frame 12 / 300"), the file name for folders (each frame of a folder
is a file of its own), loop on/off and the rate of sources that have none of their own (a folder of images
would otherwise run through in seconds). It is enabled only for seekable sources of known length (videos,
folders, cloud files, bags). A stream (a live topic, a camera, the endless demo: no length and no seeking) has
nothing to seek in, not even an end: the bar is hidden for it, not left greyed out taking a row, and shown
again for the next recording (unless the user hid it from the View menu).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QCheckBox, QDoubleSpinBox, QLabel, QProxyStyle, QSlider, QStyle, QToolBar, QWidget

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


#: How a source says it cannot decode a frame (objrec2d's video source): the frame from which it stops.
UNDECODABLE = re.compile(r"frame (\d+) of (\d+) cannot be decoded")


SLIDER_TIP = "Go to a frame of the recording (click where to go, drag and release, or arrow keys)"


class JumpToClick(QProxyStyle):
    """A click on a slider's groove puts the thumb where the click is (and starts a drag there), instead of
    moving it a page (10 frames) towards the click: on a seek bar one goes where one points."""

    def styleHint(self, hint: QStyle.StyleHint, option: Any = None, widget: Any = None,  # noqa: N802 - Qt override
                  returnData: Any = None) -> int:  # noqa: N803 - Qt's argument name
        if hint == QStyle.StyleHint.SH_Slider_AbsoluteSetButtons:
            return Qt.MouseButton.LeftButton.value
        return super().styleHint(hint, option, widget, returnData)


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
        # A style of its own (a proxy given the application's style would own, and delete, that one), kept by
        # the bar: a widget does not own the style set on it.
        self._jump_style = JumpToClick()
        self._jump_style.setParent(self)
        self.slider.setStyle(self._jump_style)
        self.slider.setMinimumWidth(300)
        self.slider.setToolTip(SLIDER_TIP)
        self.slider.valueChanged.connect(self._requested)
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
        #: Frames the source can really give, when fewer than its length (a truncated video), else None.
        self.decodable: int | None = None
        #: The index of the frame on screen (None before the first), and of a seek not answered yet.
        self.shown: int | None = None
        self.pending: int | None = None
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
        self.decodable = self.shown = self.pending = None
        self.slider.setToolTip(SLIDER_TIP)
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

    def _requested(self, index: int) -> None:
        self.pending = index
        self.seekRequested.emit(index)

    def set_position(self, index: int, length: int, where: str) -> None:
        """The frame just read: its number (shown 1-based), the source's length (-1 unknown) and where it came
        from; a frame from a file other than the source itself (a folder's image) shows the file's name."""
        self.shown = index
        if self.pending is not None and index == self.pending:
            self.pending = None
        if self.decodable is not None and length >= 0:
            length = min(length, self.decodable)
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

    def restore_position(self) -> None:
        """No frame came for the seek asked (it failed, or the source ended): the thumb goes back to the frame
        on screen, so the thumb and the counter agree."""
        self.pending = None
        if self.shown is not None and self.slider.isEnabled() and not self.slider.isSliderDown():
            self.slider.blockSignals(True)
            self.slider.setValue(min(self.shown, self.slider.maximum()))
            self.slider.blockSignals(False)

    def source_failed(self, text: str, ended: bool) -> None:
        """The source reported ``text`` (``ended``: it gives no more frames). A frame it cannot decode (a
        truncated video) limits the bar to the frames before it; the thumb goes back to the frame on screen."""
        if self.length is not None:
            match = UNDECODABLE.search(text)
            if match is not None:
                self.limit(int(match.group(1)))
            elif ended and self.pending is None and self.shown is not None:
                self.limit(self.shown + 1)  # played up to the frame on screen, then broke
        self.restore_position()

    def source_ended(self) -> None:
        """The source ran out: if before its stated length, only that many frames are there to seek in."""
        if self.length is not None and self.pending is None and self.shown is not None:
            self.limit(self.shown + 1)
        self.restore_position()

    def limit(self, frames: int) -> None:
        """Only the first ``frames`` frames can be read (fewer than the length the source states)."""
        if self.length is None or frames >= self.length or frames <= 0:
            return
        self.decodable = frames if self.decodable is None else min(self.decodable, frames)
        self.slider.blockSignals(True)
        self.slider.setMaximum(self.decodable - 1)
        self.slider.blockSignals(False)
        self.slider.setToolTip(f"Go to a frame of the recording: {self.decodable} of the {self.length} frames it "
                               "states can be decoded")
        if self.shown is not None:
            self.counter.setText(f" frame {min(self.shown, self.decodable - 1) + 1} / {self.decodable} ")

    @property
    def counter_text(self) -> str:
        return self.counter.text().strip()
