"""File > Open topic…: choose a topic of a running ROS 1 or ROS 2 system to tune on.

The dialog lists what is published now (topic and type) through the live transports of ``objrec_ros.live``,
marks the topics the pipeline's kind cannot read (greyed, with the types it does read), and answers with the
topic's source spec (``ros1:/camera/rgb/image_raw,master=http://…``), which the window opens like any other.

Listing talks to a master or waits for DDS discovery, which takes up to seconds and may never answer (a master
that is down, a firewall): it runs in a thread of its own, never in the GUI thread nor in the processing
worker (which keeps the current source playing meanwhile), and every listing has a deadline. A failure is one
line, in the dialog and in the window's message area.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Mapping

from PySide6.QtCore import QObject, Qt, QTimer, Signal
from PySide6.QtGui import QColor
from PySide6.QtWidgets import (
    QComboBox,
    QDialog,
    QDialogButtonBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QLineEdit,
    QPushButton,
    QSpinBox,
    QTreeWidget,
    QTreeWidgetItem,
    QVBoxLayout,
    QWidget,
)

from strictio.shown import printable

from .topic_chooser import LIVE_SCHEMES, LiveReading, live_defaults, live_reading, live_spec

log = logging.getLogger(__name__)

#: Lists the topics of a live system: (scheme, options, timeout s) -> [(topic, type)], or raises.
Lister = Callable[[str, Mapping[str, str], float], list[tuple[str, str]]]

#: Seconds a listing may take (ROS 2: how long discovery is given); the answer is awaited a little longer.
LIST_TIMEOUT = 3.0
#: What a listing's thread gets beyond ``LIST_TIMEOUT`` to connect and answer before the dialog gives up on it.
LIST_SLACK = 7.0
#: The extra that brings each transport (``pip install "objrec[EXTRA]"``).
EXTRAS = {"ros1": "ros", "ros2": "ros2"}


def list_live_topics(scheme: str, options: Mapping[str, str], timeout: float) -> list[tuple[str, str]]:
    """The topics published now on the system ``options`` address (the default lister; any thread)."""
    from objrec_ros.live import open_transport  # the ros extra: imported only when a topic is listed

    with open_transport(scheme, dict(options), node_name="objrec_define") as transport:
        return [(topic.name, topic.msgtype) for topic in transport.topics(timeout)]


def list_live_topics_now(scheme: str, options: Mapping[str, str], timeout: float) -> list[tuple[str, str]]:
    """``list_live_topics`` as this module holds it when called (a test or an embedding app may replace it)."""
    return list_live_topics(scheme, options, timeout)


def listing_error(scheme: str, options: Mapping[str, str], exc: BaseException) -> str:
    """One line saying why a listing failed: the missing extra, or the transport's own line (which names the
    address and what to check)."""
    title = LIVE_SCHEMES.get(scheme, scheme)
    if isinstance(exc, ImportError) or isinstance(exc.__cause__, ImportError):
        missing = getattr(exc, "name", None) or getattr(exc.__cause__, "name", None) or exc
        return (f"{title} topics cannot be listed: {missing} is not installed "
                f'(pip install "objrec[{EXTRAS.get(scheme, scheme)}]")')
    text = printable(" ".join(str(exc).split()), limit=400) or type(exc).__name__  # a peer's words, bounded
    text = text.removeprefix(f"{scheme}: ")  # the transport names itself; the line says which already
    where = options.get("master") if scheme == "ros1" else f"domain {options.get('domain', '0')}"
    return text if where and where in text else f"{title} topics on {where} cannot be listed: {text}"


class _Answer(QObject):
    """Carries a listing's outcome from its thread to the GUI thread (a queued signal)."""

    done = Signal(int, object)  # the request's number; a list of (topic, type), or the error line


class LiveTopicDialog(QDialog):
    """Lists the live topics of one transport and address; ``spec`` is the chosen topic's source spec once
    accepted. ``kind`` is the pipeline's data kind (None: every topic is offered). ``message(text, error)``
    reports each failed listing as one line (the window shows it in its message area)."""

    message = Signal(str, bool)
    #: Emitted after each listing is on screen (its topics, or the error line): for tests and embedding apps.
    listed = Signal()

    def __init__(self, kind: str | None, parent: QWidget | None = None, *, lister: Lister | None = None,
                 environ: Mapping[str, str] | None = None, timeout: float = LIST_TIMEOUT) -> None:
        super().__init__(parent)
        self.setObjectName("live_topic_dialog")
        self.setWindowTitle("Open a live topic")
        self.kind = kind
        #: Lists a system's topics (None: ``list_live_topics``, looked up when listing).
        self.lister = lister
        self.timeout = timeout
        self.spec = ""
        self._request = 0
        self._answer = _Answer(self)
        self._answer.done.connect(self._show_answer)
        self._deadline = QTimer(self)
        self._deadline.setSingleShot(True)
        self._deadline.timeout.connect(self._give_up)
        self._reading = LiveReading(None)
        defaults = live_defaults(environ)

        self.transport = QComboBox()
        for scheme, title in LIVE_SCHEMES.items():
            self.transport.addItem(title, scheme)
        self.transport.setToolTip("ROS 1: a master lists the topics; ROS 2: DDS discovery on a domain")
        self.master = QLineEdit(defaults["master"])
        self.master.setMinimumWidth(260)
        self.master.setToolTip("The ROS 1 master's URI (default: ROS_MASTER_URI)")
        self.master.returnPressed.connect(self.refresh)
        self.domain = QSpinBox()
        self.domain.setRange(0, 232)
        self.domain.setValue(int(defaults["domain"]))
        self.domain.setToolTip("The ROS 2 domain id (default: ROS_DOMAIN_ID)")
        self.address_label = QLabel()
        self.refresh_button = QPushButton("&Refresh")
        self.refresh_button.setToolTip("List what is published now")
        self.refresh_button.clicked.connect(self.refresh)
        row = QHBoxLayout()
        transport_label = QLabel("&Transport")  # mnemonics: Alt+T, Alt+M or Alt+D, Alt+R, Alt+O
        transport_label.setBuddy(self.transport)
        row.addWidget(transport_label)
        row.addWidget(self.transport)
        row.addWidget(self.address_label)
        row.addWidget(self.master, 1)
        row.addWidget(self.domain)
        row.addStretch(0)
        row.addWidget(self.refresh_button)

        self.status = QLabel()
        self.status.setObjectName("live_topic_status")
        self.status.setWordWrap(True)
        self.topics = QTreeWidget()
        self.topics.setObjectName("live_topics")
        self.topics.setHeaderLabels(["Topic", "Type"])
        self.topics.setRootIsDecorated(False)
        self.topics.setUniformRowHeights(True)
        self.topics.header().setSectionResizeMode(0, QHeaderView.ResizeMode.Stretch)
        self.topics.header().setSectionResizeMode(1, QHeaderView.ResizeMode.ResizeToContents)
        self.topics.itemSelectionChanged.connect(self._selection_changed)
        self.topics.itemDoubleClicked.connect(lambda item, _column: self._choose(item))
        self.note = QLabel()
        self.note.setWordWrap(True)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Open | QDialogButtonBox.StandardButton.Cancel)
        self.open_button = self.buttons.button(QDialogButtonBox.StandardButton.Open)
        self.open_button.setText("&Open")
        self.buttons.button(QDialogButtonBox.StandardButton.Cancel).setText("&Cancel")
        self.open_button.setEnabled(False)
        self.buttons.accepted.connect(lambda: self._choose(self.topics.currentItem()))
        self.buttons.rejected.connect(self.reject)

        layout = QVBoxLayout(self)
        layout.addLayout(row)
        layout.addWidget(self.status)
        layout.addWidget(self.topics, 1)
        layout.addWidget(self.note)
        layout.addWidget(self.buttons)
        self.resize(720, 420)
        self.transport.currentIndexChanged.connect(lambda _index: self._transport_changed())
        self._transport_changed()

    # -- what is asked --------------------------------------------------------------------------------------
    @property
    def scheme(self) -> str:
        return str(self.transport.currentData())

    def options(self) -> dict[str, str]:
        """The address of the system to list: the master (ROS 1) or the domain (ROS 2)."""
        if self.scheme == "ros1":
            return {"master": self.master.text().strip()}
        return {"domain": str(self.domain.value())}

    def set_transport(self, scheme: str) -> None:
        """Choose the transport (``ros1``, ``ros2``); listing starts again."""
        self.transport.setCurrentIndex(self.transport.findData(scheme))

    def _transport_changed(self) -> None:
        ros1 = self.scheme == "ros1"
        self.address_label.setText("&Master" if ros1 else "&Domain")
        self.address_label.setBuddy(self.master if ros1 else self.domain)
        self.master.setVisible(ros1)
        self.domain.setVisible(not ros1)
        try:
            self._reading = live_reading(self.kind, self.scheme)
        except Exception as exc:  # a broken live source plug-in: list everything, say why once
            log.warning("the %s pipeline's live source types are unknown: %s", self.kind, exc)
            self._reading = LiveReading(None)
        self.refresh()

    # -- listing, off the GUI thread ------------------------------------------------------------------------
    def refresh(self) -> None:
        """List the topics again (a listing still running is forgotten: its answer is ignored)."""
        self._request += 1
        request, scheme, options = self._request, self.scheme, self.options()
        answer, lister, timeout = self._answer, self.lister or list_live_topics_now, self.timeout

        def run() -> None:
            try:
                outcome: object = sorted(lister(scheme, options, timeout))
            except Exception as exc:  # LiveError, a missing extra, a refused connection: one line
                outcome = listing_error(scheme, options, exc)
            with contextlib.suppress(RuntimeError):  # the dialog is gone: nobody waits for this answer
                answer.done.emit(request, outcome)

        where = options.get("master") or f"domain {options.get('domain')}"
        self.status.setText(f"Listing the topics of {where}…")
        self.status.setStyleSheet("")
        self.topics.clear()
        self.open_button.setEnabled(False)
        self._deadline.start(int((timeout + LIST_SLACK) * 1000))
        threading.Thread(target=run, name="objrec-define-topics", daemon=True).start()

    def _give_up(self) -> None:
        where = self.options().get("master") or f"domain {self.options().get('domain')}"
        self._request += 1  # a late answer is ignored
        self._show_error(f"{LIVE_SCHEMES[self.scheme]} topics on {where}: no answer within "
                         f"{self.timeout + LIST_SLACK:.3g} s")
        self.listed.emit()

    def _show_answer(self, request: int, outcome: object) -> None:
        if request != self._request:
            return
        self._deadline.stop()
        if isinstance(outcome, str):
            self._show_error(outcome)
        else:
            assert isinstance(outcome, list)
            self._show_topics(outcome)
        self.listed.emit()

    def _show_error(self, text: str) -> None:
        self.status.setText(text)
        self.status.setStyleSheet("color: rgb(190, 30, 30);")
        self.note.setText("")
        self.message.emit(text, True)

    def _show_topics(self, topics: list[tuple[str, str]]) -> None:
        readable = self._reading.msgtypes
        kind = self.kind or "any"
        grey = QColor(140, 140, 140)
        usable = 0
        for name, msgtype in topics:
            item = QTreeWidgetItem([name, msgtype])
            item.setData(0, Qt.ItemDataRole.UserRole, name)
            if readable is not None and msgtype not in readable:
                item.setFlags(Qt.ItemFlag.NoItemFlags)
                for column in (0, 1):
                    item.setForeground(column, grey)
                    item.setToolTip(column, f"a {kind} pipeline does not read {msgtype}")
            else:
                usable += 1
                item.setToolTip(0, live_spec(self.scheme, name, self.options()))
            self.topics.addTopLevelItem(item)
        where = self.options().get("master") or f"domain {self.options().get('domain')}"
        if not topics:
            self.status.setText(f"Nothing is published on {where} now: start the robot's camera node, then "
                                "Refresh")
        else:
            of_kind = f", {usable} readable by this {kind} pipeline" if readable is not None else ""
            self.status.setText(f"{len(topics)} topic{'s' if len(topics) != 1 else ''} on {where}{of_kind}")
        self.status.setStyleSheet("")
        if readable is not None:
            self.note.setText(f"Greyed: types a {kind} pipeline cannot read; it reads {self._reading.text}.")
        else:
            self.note.setText("Every topic is offered: add a module (or open a parameter file) first to see "
                              "which ones the pipeline reads." if self.kind is None else "")
        first = next((self.topics.topLevelItem(i) for i in range(self.topics.topLevelItemCount())
                      if self.topics.topLevelItem(i).flags() & Qt.ItemFlag.ItemIsEnabled), None)
        if first is not None:
            self.topics.setCurrentItem(first)

    # -- the answer -----------------------------------------------------------------------------------------
    def _selection_changed(self) -> None:
        item = self.topics.currentItem()
        self.open_button.setEnabled(item is not None and bool(item.flags() & Qt.ItemFlag.ItemIsEnabled))

    def topic_names(self) -> list[tuple[str, str, bool]]:
        """(topic, type, readable) of each row listed."""
        rows = []
        for index in range(self.topics.topLevelItemCount()):
            item = self.topics.topLevelItem(index)
            rows.append((item.text(0), item.text(1), bool(item.flags() & Qt.ItemFlag.ItemIsEnabled)))
        return rows

    def choose(self, topic: str) -> None:
        """Accept ``topic`` as if double-clicked (it must be listed and readable)."""
        for index in range(self.topics.topLevelItemCount()):
            item = self.topics.topLevelItem(index)
            if item.text(0) == topic:
                self._choose(item)
                return
        raise KeyError(f"{topic} is not listed")

    def _choose(self, item: QTreeWidgetItem | None) -> None:
        if item is None or not item.flags() & Qt.ItemFlag.ItemIsEnabled:
            return
        self.spec = live_spec(self.scheme, item.text(0), self.options())
        self.accept()
