"""The message area: every report and error the window gives, whole and kept, and why each detector found nothing.

The status bar cuts a long message at its width and the next message (or a hover read-out) replaces it, so
a refusal such as a parameter's full rule was lost. Here the last ``keep`` messages stay, each with its full
text and time, errors marked; a line above them says, per detector, what it found in the frame on screen or
why it found nothing (the reason that frame's result carries). Errors of opening or saving a file
also come as a dialog, because the user is waiting for that answer.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QDockWidget,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QMessageBox,
    QVBoxLayout,
    QWidget,
)

from objrec_core import Detector, Filter, RecognitionSystem, Rect, SelectionResult, StageResults

#: How the window's file messages start when opening or saving failed (parameter_files.py).
FILE_ERROR_PREFIXES = ("Not opened:", "Not saved:")


def is_file_error(text: str) -> bool:
    """Whether a file message reports a failed open or save (those also get a dialog)."""
    return text.startswith(FILE_ERROR_PREFIXES)


def detector_reasons(results: StageResults) -> list[str]:
    """One line per detector of the frame's results: how many objects it found, or why it found none (the
    reason its result for that frame carries, else "no objects"). The reason is taken from the frame on
    screen, never from the detector, which a worker may meanwhile be running on a newer frame."""
    lines = []
    for stage in results.stages:
        if stage.role != "detector":
            continue
        found = len(stage.objects)
        if found:
            lines.append(f"{stage.id}: {found} object{'s' if found != 1 else ''}")
            continue
        reason = getattr(stage.objects, "reason", None)
        lines.append(f"{stage.id}: {reason or 'no objects'}")
    return lines


def pipeline_warnings(system: RecognitionSystem) -> list[str]:
    """What in the pipeline's order will surprise: a detector above a filter does not see that filter's
    output; a pipeline of filters only finds nothing."""
    modules = system.modules
    warnings = []
    for place, module in enumerate(modules):
        if not isinstance(module, Detector):
            continue
        later = [m.id for m in modules[place + 1:] if isinstance(m, Filter)]
        if later:
            warnings.append(f"{module.id} comes before the filter{'s' if len(later) > 1 else ''} "
                            f"{', '.join(later)}: it detects on the frame as it stands above them, "
                            "without their output")
    if modules and not any(isinstance(m, Detector) for m in modules):
        warnings.append("the pipeline has no detector: it finds nothing (add one from the Pipeline menu)")
    return warnings


def takes_selections(detector: Any) -> bool:
    """Whether a detector does anything with a selection: one that keeps ``Detector``'s default (ignore it)
    "accepts" every selection without using it, which must not be reported as taken."""
    own = getattr(type(detector), "process_area_selection", None)
    return own is not None and own is not Detector.process_area_selection


#: What a rectangle can do instead when no detector takes it (the eyedropper was unnamed).
EYEDROPPER_HINT = ("; or, to set an HSV filter's ranges from the pixels in the rectangle, drag with the HSV "
                   "eyedropper (Ctrl+E, or hold Shift while dragging)")


def selection_report(system: RecognitionSystem, rect: Rect, outcome: SelectionResult) -> tuple[str, bool]:
    """The message for a selection's outcome, and whether it is an error: who took it, who refused it and
    why, and plainly when no detector in the pipeline takes selections at all (the rectangle did nothing)."""
    where = f"{rect.width}×{rect.height} at ({rect.x}, {rect.y})"
    detectors = {d.id: d for d in system.detectors}
    taken = [name for name in outcome.accepted if takes_selections(detectors.get(name))]
    parts = []
    if taken:
        parts.append(f"selection {where} taken by {', '.join(taken)}")
    parts += [f"{module} refused the selection: {reason}" for module, reason in outcome.refused.items()]
    if not parts:
        ignored = ", ".join(outcome.accepted)
        parts.append(f"selection {where} did nothing: no detector in the pipeline takes selections"
                     + (f" ({ignored} ignore{'s' if len(outcome.accepted) == 1 else ''} them)" if ignored else "")
                     + "; add one that learns a target (a feature detector) from the Pipeline menu"
                     + EYEDROPPER_HINT)
    return "; ".join(parts), bool(outcome.refused) or not taken


class MessageArea(QDockWidget):
    """A dock with the per-detector line and the last ``keep`` messages, newest at the bottom."""

    def __init__(self, parent: QWidget | None = None, keep: int = 200) -> None:
        super().__init__("Messages", parent)
        self.setObjectName("messages_dock")
        self.keep = keep
        self.setFeatures(QDockWidget.DockWidgetFeature.DockWidgetMovable
                         | QDockWidget.DockWidgetFeature.DockWidgetFloatable
                         | QDockWidget.DockWidgetFeature.DockWidgetClosable)
        body = QWidget()
        layout = QVBoxLayout(body)
        layout.setContentsMargins(4, 2, 4, 2)
        self.detectors = QLabel()
        self.detectors.setObjectName("detector_reasons")
        self.detectors.setWordWrap(True)
        self.detectors.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.detectors.setToolTip("What each detector found in the frame on screen, or why it found nothing")
        layout.addWidget(self.detectors)
        self.list = QListWidget()
        self.list.setWordWrap(True)
        self.list.setAlternatingRowColors(True)
        self.list.setToolTip("The last messages, whole (select and Ctrl+C to copy)")
        layout.addWidget(self.list)
        self.setWidget(body)
        self._detector_lines: tuple[str, ...] = ()
        self._warnings: tuple[str, ...] = ()
        self.dialog: QMessageBox | None = None

    # -- messages -----------------------------------------------------------------------------------------
    def add(self, text: str, error: bool = False) -> None:
        """Keep ``text`` whole; the oldest goes once there are more than ``keep``."""
        item = QListWidgetItem(f"{time.strftime('%H:%M:%S')}  {'error: ' if error else ''}{text}")
        item.setData(Qt.ItemDataRole.UserRole, text)
        item.setToolTip(text)
        if error:
            item.setForeground(QColor(190, 30, 30))
        self.list.addItem(item)
        while self.list.count() > self.keep:
            self.list.takeItem(0)
        self.list.scrollToBottom()

    def messages(self) -> list[str]:
        """The kept messages' full texts, oldest first."""
        return [str(self.list.item(i).data(Qt.ItemDataRole.UserRole)) for i in range(self.list.count())]

    def show_dialog(self, text: str, title: str = "objrec-define") -> None:
        """An error the user waits for (a file not opened or saved), as a window-modal dialog that does not
        block the event loop (``open``, not ``exec``)."""
        if self.dialog is not None:
            self.dialog.close()
        self.dialog = QMessageBox(QMessageBox.Icon.Warning, title, text, QMessageBox.StandardButton.Ok,
                                  self.parentWidget())
        self.dialog.open()

    # -- detectors ----------------------------------------------------------------------------------------
    def show_detectors(self, lines: Sequence[str]) -> None:
        """The per-detector line for the frame on screen (repainted only when it changed)."""
        lines = tuple(lines)
        if lines != self._detector_lines:
            self._detector_lines = lines
            self.detectors.setText("Detectors: " + " · ".join(lines) if lines else "No detector in the pipeline")

    @property
    def detector_text(self) -> str:
        return self.detectors.text()

    def check_pipeline(self, system: Any) -> None:
        """Say once what is odd about the pipeline's order (again after every change that alters it)."""
        warnings = tuple(pipeline_warnings(system))
        for warning in warnings:
            if warning not in self._warnings:
                self.add(warning, error=True)
        self._warnings = warnings
