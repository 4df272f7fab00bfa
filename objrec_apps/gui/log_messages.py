"""Warnings the sources log, brought to the window's message area.

A folder's file that cannot be read is skipped with one warning naming it and why
(``objrec_core.folder_source``): on the command line that warning is the report, but a GUI user never sees
stderr. The warnings of the loggers named here also go to the message area, from whichever thread logged
them (the processing thread reads the folder), through a queued signal.
"""

from __future__ import annotations

import contextlib
import logging

from PySide6.QtCore import QObject, Signal

#: The loggers whose warnings a GUI user must see: files of a folder skipped (2D images, 3D clouds).
SOURCE_LOGGERS = ("objrec_core.folder_source",)


class _Emitter(QObject):
    logged = Signal(str)


class LogToMessages(logging.Handler):
    """A logging handler that emits ``logged(text)`` (in the GUI thread when connected there) for every
    record at WARNING or above of ``loggers``. ``attach`` starts, ``detach`` ends it."""

    def __init__(self, loggers: tuple[str, ...] = SOURCE_LOGGERS) -> None:
        super().__init__(logging.WARNING)
        self.loggers = loggers
        self.emitter = _Emitter()
        self.logged = self.emitter.logged

    def emit(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(RuntimeError):  # the window (and its emitter) is gone: nowhere to show it
            self.logged.emit(record.getMessage())

    def attach(self) -> None:
        for name in self.loggers:
            logging.getLogger(name).addHandler(self)

    def detach(self) -> None:
        for name in self.loggers:
            logging.getLogger(name).removeHandler(self)
