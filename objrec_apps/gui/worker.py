"""Processing off the GUI thread: a worker runs the DefinitionDirector, the GUI shows the newest result.

The worker is the director's ``StageView``: every result goes into a one-slot mailbox that the next result
overwrites, and the GUI is told with at most one queued signal at a time. A GUI that cannot keep up therefore
skips frames instead of queueing them, and never freezes at camera rate.

Changes reach the worker through the observer (``reprocess``): after any change that can alter the
result (a parameter, a module's state or object name, the pipeline) the frame last read is processed again
at once, so the user sees the effect of every change without waiting for the next frame, and also
while paused or after a file or image source has ended.
"""

from __future__ import annotations

import atexit
import logging
import threading
import time
import weakref
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from PySide6.QtCore import QObject, Signal

from objrec_core import Change, DefinitionDirector, Frame, FrameSource, SourceError, StageResults, open_source
from strictio import InputError

from .preview import PREVIEW_AFTER_S, PreviewRunner
from .seek_bar import SourceFacts

log = logging.getLogger(__name__)


@dataclass
class Shown:
    """A result in the mailbox, with the parameter generation in force when its processing began."""

    results: StageResults
    generation: int
    started: float  # time.perf_counter() when processing began
    prepared: Any = None  # what the window's prepare hook made of it in the worker thread
    #: 0 for a full result; k for a coarse preview made on every k-th row and column (preview.py).
    preview_step: int = 0

    @property
    def order(self) -> tuple[int, int]:
        """What may replace what on screen: a newer parameter set, and the full result over its preview."""
        return self.generation, 0 if self.preview_step else 1


#: Changes that cannot alter what the pipeline finds: no reprocessing for them.
UNSEEN_CHANGES = frozenset({"description", "file"})


def waits_for_frames(source: FrameSource | None) -> bool:
    """Whether ``source`` may wait for its next frame without end (a live topic) and so hears ``watch_stop``:
    its iteration ends when told, and starts again where it was if the source is kept."""
    return source is not None and type(source).watch_stop is not FrameSource.watch_stop


class _Watcher:
    """Observes the system and its modules for the worker (from any thread)."""

    def __init__(self, worker: ProcessingWorker) -> None:
        self.worker = worker

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        if not changes or any(c.name not in UNSEEN_CHANGES for c in changes):
            self.worker.reprocess()



def _stop_at_exit(worker: weakref.ref[ProcessingWorker]) -> None:
    alive = worker()
    if alive is not None and alive.running:
        alive.stop(2.0)

class ProcessingWorker(QObject):
    """Runs frames from a source through a DefinitionDirector in a thread of its own.

    ``fps_limit`` paces sources that are not cameras, so no core is burnt on frames nobody sees; ``None``
    runs them flat out (benchmarks). A recording plays at its own rate (``FrameSource.rate``: a 15 fps video
    at 15), a source without one but of known length (a folder, a cloud file) at ``still_rate``, anything
    else at ``fps_limit``. ``loop`` starts a seekable source again at its end; ``seek(n)`` jumps to frame n.
    """

    resultReady = Signal()  # noqa: N815 - Qt's signal naming
    sourceFacts = Signal(object)  # noqa: N815 - Qt's signal naming: the SourceFacts of the source just opened
    sourceOpened = Signal(str, str)  # noqa: N815 - Qt's signal naming: the source's name and data kind ("" unknown)
    sourceEnded = Signal(str)  # noqa: N815 - Qt's signal naming
    failed = Signal(str)
    pausedChanged = Signal(bool)  # noqa: N815 - Qt's signal naming
    callDone = Signal(object, object)  # noqa: N815 - Qt's signal naming
    #: A frame was read: its index, the source's length (-1 unknown), where it came from (a folder's file).
    positionChanged = Signal(int, int, str)  # noqa: N815 - Qt's signal naming

    def __init__(
        self,
        director: DefinitionDirector,
        *,
        fps_limit: float | None = 30.0,
        prepare: Callable[[StageResults], Any] | None = None,
        parent: QObject | None = None,
        previews: bool = True,
    ) -> None:
        super().__init__(parent)
        self.director = director
        self.fps_limit = fps_limit
        #: Frames per second for sources of known length without a rate of their own (folders of images).
        self.still_rate = 5.0
        #: Start a seekable source again when it ends.
        self.loop = False
        #: Called in the worker thread on every result (drawing, merging clouds), so the GUI only paints.
        self.prepare = prepare
        self._processing_lock = threading.Lock()
        director.set_view(self)
        self._cond = threading.Condition()
        self._thread: threading.Thread | None = None
        self._stopping = False
        self._paused = False
        self._step_pending = False
        self._reprocess_pending = False
        self._commands: list[Callable[[], None]] = []
        self._source: FrameSource | None = None
        #: Set to end the open source's wait for its next frame (a live topic gone quiet), so opening another
        #: source or closing the window is not held up by a camera that sends nothing.
        self._source_stop = threading.Event()
        #: The open source's iteration ended because ``_source_stop`` was set, not because it ran out.
        self._interrupted = False
        #: The data kind the source delivers, where known: frames of another kind never reach the pipeline
        #: (after File > Open switches between 2D and 3D, until the new source is open).
        self._source_kind: str | None = None
        self._iterator: Iterator[Frame] | None = None
        self._ended = False
        self._last_frame: Frame | None = None
        self._facts: SourceFacts | None = None
        self._last_read = 0.0  # when reading the previous new frame began: the frame-rate clock
        self._generation = 0
        self._processing_generation = 0
        self._processing_started = 0.0
        self._latest: Shown | None = None
        self._notified = False
        self._last_error = ""
        #: Frames processed, and how many of them were overwritten before the GUI took them.
        self.processed = 0
        self.dropped = 0
        #: Results never shown because a result of a newer parameter set was already in the mailbox or on
        #: screen (a full result overtaken by the next change's preview, a preview by its full result).
        self.discarded = 0
        self._offered: tuple[int, int] = (-1, 0)  # the order of the newest result put in the mailbox
        #: Coarse previews after a change when a full result is slow (preview.py); None: previews off.
        self.previewer = PreviewRunner(director.system, self._offer_preview) if previews else None
        self._full_seconds = 0.0  # the processing time of the newest full result
        self._watcher = _Watcher(self)
        self._watched: tuple[Any, ...] = ()
        director.system.add_observer(self._watcher)
        self._watch_modules()

    # -- control, from any thread ---------------------------------------------------------------------
    def start(self) -> None:
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._run, name="objrec-define-worker", daemon=True)
        self._thread.start()
        # An application that ends with its window still open (never closed, so never stopped) must not leave
        # this thread running into the interpreter's shutdown, where it dies with a traceback half printed.
        atexit.register(_stop_at_exit, weakref.ref(self))

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread and close the source; safe to call twice."""
        with self._cond:
            self._stopping = True
            self._source_stop.set()
            self._cond.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
            if self._thread.is_alive():
                log.warning("the processing thread did not stop within %.1f s", timeout)
        self._thread = None
        if self.previewer is not None:
            self.previewer.stop(timeout)
        self.director.system.remove_observer(self._watcher)
        for module in self._watched:
            module.remove_observer(self._watcher)
        self._watched = ()
        if self._source is not None:
            self._source.close()
            self._source = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def paused(self) -> bool:
        return self._paused

    @property
    def ended(self) -> bool:
        return self._ended

    @property
    def source(self) -> FrameSource | None:
        return self._source

    @property
    def facts(self) -> SourceFacts | None:
        """The open source's length, rate and whether it seeks, read once in this thread when it opened (None
        before a source opened, or when the source could not say)."""
        return self._facts

    @property
    def source_kind(self) -> str | None:
        """The data kind of the source's frames, where known."""
        return self._source_kind

    @property
    def generation(self) -> int:
        """Counts parameter and pipeline changes; each Shown carries the count in force for it."""
        return self._generation

    def set_paused(self, paused: bool) -> None:
        with self._cond:
            changed = paused != self._paused
            self._paused = paused
            self._last_read = 0.0
            self._cond.notify_all()
        if changed:
            self.pausedChanged.emit(paused)

    def step(self) -> None:
        """Process exactly one new frame (pauses first)."""
        self.set_paused(True)
        with self._cond:
            self._step_pending = True
            self._cond.notify_all()

    def seek(self, index: int) -> None:
        """Read frame ``index`` next (and process it, paused or not); ignored for sources that cannot seek."""

        def command() -> None:
            source = self._source
            if source is None or not source.seekable:
                return
            try:
                self._iterator = source.frames_from(index)
            except Exception as exc:  # a source's own error: reported, the old position kept
                self.failed.emit(f"{source.name}: cannot go to frame {index}: {exc}")
                return
            with self._cond:
                self._ended = False
                self._step_pending = True
                self._last_read = 0.0

        self._submit(command)

    def frame_period(self) -> float | None:
        """Seconds between two frames read from the open source; None reads as fast as it delivers."""
        source = self._source
        if self.fps_limit is None or source is None or getattr(source, "is_camera", False):
            return None
        facts = self._facts if self._facts is not None and self._facts.name == source.name else None
        rate = facts.rate if facts is not None else None
        if not rate or rate <= 0:
            known_length = facts is not None and facts.length is not None
            rate = self.still_rate if known_length else self.fps_limit
        return 1.0 / float(rate) if rate and rate > 0 else None

    def reprocess(self) -> None:
        """Parameters or the pipeline changed: show their effect as soon as possible (and, when the pipeline
        is slow, a coarse preview of it at once)."""
        with self._cond:
            self._generation += 1
            self._reprocess_pending = True
            generation, frame = self._generation, self._last_frame
            self._cond.notify_all()
        wanted = self.director.system.kind
        same_kind = self._source_kind is None or wanted is None or wanted == self._source_kind
        if self.previewer is not None and frame is not None and same_kind and self._full_seconds > PREVIEW_AFTER_S:
            self.previewer.request(generation, frame, self._full_seconds)

    def open_source(self, spec: str, kind: str | None) -> None:
        """Open a source by its spec for data ``kind`` (None: the kind whose source takes the spec), in the
        worker thread: a camera may take a while."""

        def command() -> None:
            try:
                source = open_source(spec, kind)
            except Exception as exc:  # SourceError, UnknownModuleError, a camera driver's own error
                self.failed.emit(str(exc))
                self._keep_source()
                return
            self._install(source, kind)

        self._submit(command, interrupt=True)

    def set_source(self, source: FrameSource, kind: str | None = None) -> None:
        """Use an already opened source (of data ``kind``; None: the kind its type declares, if any)."""
        self._submit(lambda: self._install(source, kind), interrupt=True)

    def call(self, function: Callable[[], Any], done: Callable[[Any], None] | None = None) -> None:
        """Run ``function`` in the worker thread between two frames; ``done(result)`` then runs in the GUI."""

        def command() -> None:
            try:
                with self._processing_lock:  # like a frame: never while the GUI loads a file
                    result: Any = function()
            except Exception as exc:
                log.exception("a call in the processing thread failed")
                result = exc
            if done is not None:
                self.callDone.emit(done, result)

        self._submit(command)

    def exclusive(self) -> threading.Lock:
        """Hold this (``with worker.exclusive():``) to change modules between two frames, never during one."""
        return self._processing_lock

    def take(self) -> Shown | None:
        """The newest result, once (the GUI calls this on resultReady)."""
        with self._cond:
            shown, self._latest = self._latest, None
            self._notified = False
        return shown

    # -- the director's view (worker thread) --------------------------------------------------------------
    def show_stages(self, results: StageResults) -> None:
        self._full_seconds = results.seconds
        shown = Shown(results, self._processing_generation, self._processing_started, self._prepared(results))
        with self._cond:
            self.processed += 1
        self.offer(shown)

    def _prepared(self, results: StageResults) -> Any:
        if self.prepare is None:
            return None
        try:
            return self.prepare(results)
        except Exception:
            log.exception("preparing frame %d for display failed", results.frame.index)
            return None

    def _offer_preview(self, results: StageResults, generation: int, step: int) -> None:
        """A coarse preview from the preview thread (preview.py)."""
        self.offer(Shown(results, generation, time.perf_counter() - results.seconds, self._prepared(results), step))

    def offer(self, shown: Shown) -> bool:
        """Put a result in the mailbox for the GUI, unless a result of a newer parameter set (or the full result
        of the same one, over a preview) is already there or was: a stale result is never shown over a newer
        one. False when discarded."""
        with self._cond:
            if shown.order < self._offered:
                self.discarded += 1
                return False
            self._offered = shown.order
            if self._latest is not None and not self._latest.preview_step:  # a preview is no frame of its own
                self.dropped += 1
            self._latest = shown
            notify = not self._notified
            self._notified = True
        if notify:
            self.resultReady.emit()
        return True

    # -- the thread ---------------------------------------------------------------------------------------
    def _submit(self, command: Callable[[], None], interrupt: bool = False) -> None:
        """Queue ``command`` for the worker thread; ``interrupt`` also ends the open source's wait for a frame
        (a live topic gone quiet would otherwise hold the command back until its next message)."""
        with self._cond:
            self._commands.append(command)
            if interrupt:
                self._source_stop.set()
            self._cond.notify_all()

    def _watch_modules(self) -> None:
        modules = self.director.system.modules
        for module in self._watched:
            if not any(module is m for m in modules):
                module.remove_observer(self._watcher)
        for module in modules:
            module.add_observer(self._watcher)
        self._watched = modules

    def _install(self, source: FrameSource, kind: str | None = None) -> None:
        old = self._source
        with self._cond:
            self._source_stop, self._interrupted = threading.Event(), False
        source.watch_stop(self._source_stop)
        self._source, self._iterator, self._ended, self._last_frame = source, iter(source), False, None
        self._source_kind = kind or source.kind
        self._last_read = 0.0
        if old is not None and old is not source:
            old.close()
        try:
            facts: SourceFacts | None = SourceFacts.of(source)
        except Exception as exc:  # a recording that cannot say its length or rate: played, not seekable
            log.warning("%s: length and rate unknown: %s", source.name, exc)
            facts = None
        self._facts = facts
        self.sourceFacts.emit(facts)
        self.sourceOpened.emit(source.name, self._source_kind or "")

    def _keep_source(self) -> None:
        """The source meant to replace the open one did not open: the open one plays on. A live topic that
        stopped waiting to make way is iterated again (its subscription is still there: it goes on with the
        newest frame); any other source never heard the request."""
        source = self._source
        with self._cond:
            self._source_stop = threading.Event()
        if source is None:
            return
        source.watch_stop(self._source_stop)
        if self._interrupted:
            with self._cond:
                self._iterator, self._ended, self._interrupted = iter(source), False, False
            log.info("%s plays on: the source meant to replace it did not open", source.name)

    def _has_work(self) -> bool:
        if self._commands or self._step_pending:
            return True
        if self._reprocess_pending and self._last_frame is not None:
            return True
        return self._source is not None and not self._paused and not self._ended


    def _run(self) -> None:
        try:
            self._serve()
        except RuntimeError as exc:
            # The window was destroyed without closing (the application ended while it was open), and with it
            # the Qt objects this thread reports to: there is no one left to tell, so the thread just ends.
            if "already deleted" not in str(exc):
                raise
            log.debug("the worker ends with its window: %s", exc)

    def _serve(self) -> None:
        while True:
            with self._cond:
                while not self._stopping and not self._has_work():
                    self._cond.wait()
                if self._stopping:
                    return
                commands, self._commands = self._commands, []
            for command in commands:
                command()
            if self.director.system.modules != self._watched:
                self._watch_modules()
            frame = self._next_frame()
            if frame is not None:
                self._process(frame)

    def _next_frame(self) -> Frame | None:
        with self._cond:
            if self._reprocess_pending and not self._step_pending:
                # The frame already read, processed again now: a new one may take a while to come (a demo
                # frame is drawn, a camera waits for its next exposure), the change should not.
                if self._last_frame is None:
                    self._reprocess_pending = False
                if self._last_frame is not None or self._paused or self._ended:
                    return self._last_frame
            if self._source is None or self._ended or (self._paused and not self._step_pending):
                return None
            period = self.frame_period()
            if period is not None and self._last_read and not self._step_pending:
                due = self._last_read + period
                while not (self._stopping or self._commands or self._reprocess_pending or self._paused):
                    remaining = due - time.perf_counter()
                    if remaining <= 0:
                        break
                    self._cond.wait(remaining)
                if self._stopping or self._commands or (self._paused and not self._step_pending):
                    return None
            self._step_pending = False
            iterator = self._iterator
        assert iterator is not None
        self._last_read = time.perf_counter()
        try:
            frame = next(iterator)
        except StopIteration:
            if self._source_stop.is_set() and waits_for_frames(self._source):
                self._ended = self._interrupted = True  # to make way for another source (or for closing)
                return None
            frame = self._loop_round()
            if frame is not None:
                self._last_frame = frame
                self._report_position(frame)
                return frame
            self._ended = True
            self.sourceEnded.emit(self._source.name if self._source is not None else "")
            return None
        except Exception as exc:  # SourceError says what broke; anything else from a source too, not silently
            self._ended = True
            # A bad file (a truncated video: InputError naming the file and frame) is the user's data, not a
            # bug: its one line goes to the window, with no traceback on the terminal.
            if not isinstance(exc, (SourceError, InputError)):
                log.exception("source %s failed", self._source.name if self._source is not None else "")
            self.failed.emit(str(exc) if isinstance(exc, SourceError) else f"the source failed: {exc}")
            return None
        self._last_frame = frame
        self._report_position(frame)
        return frame

    def _loop_round(self) -> Frame | None:
        """With ``loop`` on, the first frame of the source again (None when off or it cannot seek)."""
        source = self._source
        if not self.loop or source is None or not source.seekable:
            return None
        self._iterator = source.frames_from(0)
        return next(self._iterator, None)

    def _report_position(self, frame: Frame) -> None:
        source = self._source
        length = source.length if source is not None else None
        self.positionChanged.emit(frame.index, -1 if length is None else int(length), frame.source)

    def _process(self, frame: Frame) -> None:
        wanted = self.director.system.kind
        if self._source_kind is not None and wanted is not None and wanted != self._source_kind:
            log.debug("frame %d of a %s source skipped: the pipeline is now %s", frame.index, self._source_kind, wanted)
            return
        with self._cond:
            self._reprocess_pending = False
            self._processing_generation = self._generation
        self._processing_started = time.perf_counter()
        try:
            with self._processing_lock:
                self.director.process(frame)
        except Exception as exc:  # a module that fails on some frame must not end the session
            message = f"processing frame {frame.index} failed: {type(exc).__name__}: {exc}"
            if message != self._last_error:
                log.exception("%s", message)
                self.failed.emit(message)
            self._last_error = message
        else:
            self._last_error = ""
