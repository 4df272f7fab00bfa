"""Coarse previews while tuning a slow pipeline: a parameter change shows a first result at once.

The shipped shape system takes 0.4-1.8 s on the 307,200-point mug scan, so after every change the panel
felt dead. When the last full result took longer than ``PREVIEW_AFTER_S``, a change also runs the pipeline,
in a thread of its own, on a thinned copy of the frame on screen (every k-th row and column of an organized
cloud: a sixteenth of the points at k = 4), and that result is shown first, marked as a preview; the full
result replaces it when it arrives. The worker's mailbox never shows a result of an older parameter set
over a newer one (``ProcessingWorker.offer``), so neither a late preview nor a stale full result can.

The preview runs the live modules, as the full processing does: a module keeps no per-frame state and reads
one parameter snapshot per call (``Detector.detect``: "the GUI's thread and a worker ... may call detect on
one instance at once"). It runs beside the full processing, not after it, so a change made while a full
result is being computed is previewed at once too.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from objrec_core import Frame, RecognitionSystem, StageResults

from .kind_guard import KindGuardedDirector

log = logging.getLogger(__name__)

#: A full result slower than this (seconds) gets a coarse preview first after each change.
PREVIEW_AFTER_S = 0.15
#: What a preview should cost (seconds): the thinning step is chosen from the full result's time for it.
PREVIEW_BUDGET_S = 0.04
#: The thinning steps used: 2 keeps a quarter of an organized cloud's points, 4 a sixteenth. Beyond 4 the
#: detectors' absolute thresholds drop what they find: on the mug scan at 1/36 the cylinder has 71 inliers,
#: fewer than the shipped min_inliers of 80 (229 at 1/16).
MIN_STEP, MAX_STEP = 2, 4

#: Called with a preview's results, the parameter generation it was made for and its thinning step.
Publish = Callable[[StageResults, int, int], None]


def preview_step(full_seconds: float) -> int:
    """The thinning step (k: every k-th row and column) that brings a pipeline taking ``full_seconds`` on the
    whole frame near ``PREVIEW_BUDGET_S``: the cost falls with the points, k² times."""
    wanted = math.sqrt(max(full_seconds, 0.0) / PREVIEW_BUDGET_S)
    return int(min(max(math.ceil(wanted), MIN_STEP), MAX_STEP))


def coarse_frame(data: Any, step: int) -> Any | None:
    """A thinned copy of a point cloud (anything with ``points`` N x 3, ``colors``, ``width`` and ``height``,
    as ``objrec3d.PointCloud``): every ``step``-th row and column of an organized cloud (still organized, so
    normals come from image neighbours), every ``step``²-th point of an unorganized one. None for data that is
    no such cloud (an image: a 2D pipeline is fast enough, and its parameters are in pixels)."""
    points = getattr(data, "points", None)
    width, height = getattr(data, "width", None), getattr(data, "height", None)
    if not isinstance(points, np.ndarray) or points.ndim != 2 or points.shape[1] != 3:
        return None
    if not isinstance(width, int) or not isinstance(height, int) or width * height != points.shape[0]:
        return None
    colors = getattr(data, "colors", None)
    colors = colors if isinstance(colors, np.ndarray) and colors.shape[0] == points.shape[0] else None
    origin = getattr(data, "sensor_origin", (0.0, 0.0, 0.0))
    try:
        if height > 1:
            grid = points.reshape(height, width, 3)[::step, ::step]
            thin_colors = None if colors is None else colors.reshape(height, width, -1)[::step, ::step]
            rows, columns = grid.shape[:2]
            return type(data)(np.ascontiguousarray(grid.reshape(-1, 3)),
                              None if thin_colors is None else thin_colors.reshape(rows * columns, -1),
                              columns, rows, sensor_origin=origin)
        keep = slice(None, None, step * step)
        return type(data)(np.ascontiguousarray(points[keep]), None if colors is None else colors[keep],
                          sensor_origin=origin)
    except (TypeError, ValueError) as exc:  # a cloud type that is built otherwise: no preview, no harm
        log.debug("no coarse copy of %s: %s", type(data).__name__, exc)
        return None


class PreviewRunner:
    """Makes the previews in a thread of its own; only the newest request is run (a drag's intermediate
    values are skipped). ``made`` counts the previews published."""

    def __init__(self, system: RecognitionSystem, publish: Publish) -> None:
        self.system = system
        self.publish = publish
        #: A director of its own: the window's keeps the frame a selection is drawn on.
        self.director = KindGuardedDirector(system)  # a pipeline replaced by another kind skips the frame
        self.made = 0
        self._cond = threading.Condition()
        self._request: tuple[int, Frame, int] | None = None
        self._thread: threading.Thread | None = None
        self._stopping = False
        self._coarse: tuple[Any, int, Any] | None = None  # (the frame data, step, its coarse copy)

    def request(self, generation: int, frame: Frame, full_seconds: float) -> bool:
        """Preview parameter generation ``generation`` on ``frame`` (whose full result took
        ``full_seconds``); False when the frame has no coarse form."""
        step = preview_step(full_seconds)
        if self._coarse_of(frame.data, step) is None:
            return False
        with self._cond:
            if self._stopping:
                return False
            self._request = (generation, frame, step)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="objrec-define-preview", daemon=True)
                self._thread.start()
            self._cond.notify_all()
        return True

    def stop(self, timeout: float = 5.0) -> None:
        with self._cond:
            self._stopping = True
            self._cond.notify_all()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)

    def _coarse_of(self, data: Any, step: int) -> Any | None:
        """``coarse_frame`` of the frame on screen, made once per frame and step (a drag previews one frame
        many times)."""
        cached = self._coarse
        if cached is not None and cached[0] is data and cached[1] == step:
            return cached[2]
        coarse = coarse_frame(data, step)
        self._coarse = (data, step, coarse)
        return coarse

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._request is None and not self._stopping:
                    self._cond.wait()
                if self._stopping:
                    return
                request, self._request = self._request, None
            assert request is not None
            generation, frame, step = request
            data = self._coarse_of(frame.data, step)
            if data is None:
                continue
            coarse = Frame(data, frame.stamp, frame.index, frame.source, None, frame.frame_id, frame.stamp_ns)
            started = time.perf_counter()
            try:
                results = self.director.process(coarse)
            except Exception as exc:  # the full processing reports a module's failure; a preview just skips
                log.debug("preview of generation %d failed: %s", generation, exc)
                continue
            if results is None:  # the pipeline is now of another kind than the frame
                continue
            log.debug("preview of generation %d at 1/%d: %.0f ms", generation, step * step,
                      (time.perf_counter() - started) * 1000)
            self.made += 1
            self.publish(results, generation, step)

