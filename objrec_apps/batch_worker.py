"""What an objrec-batch worker does with one source: build the system from the parameter file, run it over
the source, write the detections, and say how it went.

Kept apart from ``batch.py`` so that a Dask worker imports only this (no Dask client code, no argparse) and
so that the same function runs in-process for tests and benchmarks. Workers receive paths, never contents:
the parameter file and the recording are read where the work is done.
"""

from __future__ import annotations

import logging
import os
import re
import sys
import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from objrec_core import (
    DetectedObjectArray,
    DetectionDirector,
    RunStats,
    SourceSpec,
    build_system,
    open_source,
    source_schemes,
)

from .cli import EscapingFormatter
from .output_contract import Ending, Output, RunEnd

log = logging.getLogger("objrec.batch")

#: Output formats and the suffix of their files.
FORMATS = {"jsonl": ".jsonl", "mcap": ".mcap"}

OK = "ok"
FAILED = "failed"
#: Interrupted half way: the numbers and the output hold the frames done before the stop.
STOPPED = "stopped"
#: Never started: the batch was interrupted first.
CANCELLED = "cancelled"
#: How often a running source asks the scheduler whether the batch was interrupted.
STOP_POLL_SECONDS = 0.5


@dataclass
class SourceResult:
    """One row of the summary: what a source gave, or why it did not."""

    source: str
    output: str
    frames: int = 0
    frames_with_objects: int = 0
    objects: int = 0
    seconds: float = 0.0
    status: str = OK
    runs: int = 1  # 2: its first worker process died under it (or under the source before it) and it ran again

    @property
    def rate(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def shown_status(self) -> str:
        """The status as the table shows it: a source that ran again after a worker died says so."""
        if self.runs > 1 and not self.status.startswith(FAILED):
            times = "twice" if self.runs == 2 else f"{self.runs} times"
            return f"{self.status} (run {times}: a worker process died under it)"
        return self.status

    def to_row(self) -> dict[str, Any]:
        """The summary.csv row (frames/s rounded, as the table shows it)."""
        row = asdict(self)
        row["seconds"] = round(self.seconds, 3)
        row["frames_per_s"] = round(self.rate, 2)
        return row


def count_kept_lines(result: SourceResult, output: Path) -> None:
    """Set a source's counts from the JSON Lines its run wrote before its worker process died (each whole line is
    a frame, its ``objects`` the objects found): the summary then says what the kept file holds rather than 0
    frames. A line cut short by the death, or one that is not a detection, is not counted."""
    import json

    frames = with_objects = objects = 0
    try:
        with open(output, encoding="utf-8", errors="replace") as stream:
            for line in stream:
                if not line.endswith("\n"):
                    break
                try:
                    found = json.loads(line).get("objects")
                except (ValueError, AttributeError):
                    continue
                if isinstance(found, list):
                    frames += 1
                    with_objects += bool(found)
                    objects += len(found)
    except OSError as exc:
        log.debug("cannot count the lines of %s: %s", output, exc)
        return
    result.frames, result.frames_with_objects, result.objects = frames, with_objects, objects


def one_line(exc: BaseException) -> str:
    """An error as one line: a corrupt recording's library error can span many, or be empty."""
    text = " ".join(str(exc).split())
    if not text or isinstance(exc, AssertionError | KeyError | IndexError | TypeError | ValueError | AttributeError):
        text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text


def worker_deaths(key: str, dask_scheduler: Any = None) -> int:
    """Run on the scheduler (``Client.run_on_scheduler``): how many worker processes died while they held the
    task ``key`` (Dask's ``suspicious`` count; 0 for a task it no longer knows)."""
    task = dask_scheduler.tasks.get(key) if dask_scheduler is not None else None
    return int(getattr(task, "suspicious", 0) or 0)


# -- output names ---------------------------------------------------------------------------------------------
_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")


def output_stem(spec: str, schemes: set[str] | None = None) -> str:
    """The file name an output takes from its source: a path's stem (a folder's name), else the path inside a
    ``scheme:`` spec, else the spec itself made safe for a file name. ``schemes``: the registered ones."""
    if schemes is None:
        schemes = source_schemes()
    parsed = SourceSpec.parse(spec, schemes)
    if parsed.path is not None:
        path = parsed.path
        name = path.name if path.is_dir() or not path.suffix else path.stem
    else:
        paths = [v for v in (*parsed.positional, *parsed.options.values()) if "/" in v or os.sep in v]
        if paths:
            path = Path(paths[0].rstrip("/" + os.sep))
            name = path.stem if path.suffix else path.name
        else:
            name = spec
    name = _UNSAFE.sub("_", name).strip("._-")
    return name or "source"


def output_names(specs: Iterable[str], suffix: str, schemes: set[str] | None = None) -> list[str]:
    """One file name per source, in order, unique even where stems clash (``clip``, ``clip-2``, ...) and on
    file systems that ignore case."""
    if schemes is None:
        schemes = source_schemes()
    used: set[str] = set()
    names = []
    for spec in specs:
        stem = output_stem(spec, schemes)
        candidate, number = stem, 1
        while (candidate + suffix).casefold() in used:
            number += 1
            candidate = f"{stem}-{number}"
        used.add((candidate + suffix).casefold())
        names.append(candidate + suffix)
    return names


def _worker_logging() -> None:
    """A worker process has no handler of its own for objrec's warnings (a skipped image, a dropped message):
    give them the command's prefix on the worker's stderr. Does nothing where logging is set up already."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(EscapingFormatter("objrec-batch (worker): %(levelname)s: %(message)s"))
    logging.basicConfig(level=logging.WARNING, handlers=[handler])


class _StopFlag:
    """The batch's stop request, a Dask Event, seen through the ``is_set()`` the run loop checks after every
    frame; the scheduler is asked at most every STOP_POLL_SECONDS, so frames cost no round trip."""

    def __init__(self, name: str) -> None:
        from distributed import Event

        self._event = Event(name)
        self._set = False
        self._next = 0.0

    def is_set(self) -> bool:
        now = time.monotonic()
        if not self._set and now >= self._next:
            self._next = now + STOP_POLL_SECONDS
            try:
                self._set = bool(self._event.is_set())
            except Exception:  # the scheduler went away: the cluster is closing, stop here
                self._set = True
        return self._set


def _note_start(queue: str, output: str) -> None:
    """Tell the batch this source starts (``starts_queue``: a Dask queue it counts, see batch._Starts)."""
    try:
        from distributed import Queue

        Queue(queue).put(output)
    except Exception:  # a note for the summary, never a reason to fail the source
        log.debug("cannot note the start of %s", output, exc_info=True)


# -- one source ------------------------------------------------------------------------------------------------
def _open_output(path: Path, fmt: str, array_type: type[DetectedObjectArray], topic: str | None,
                 object_name: str) -> Output:
    """The output of one source's detections, the same as objrec-detect's ``--output`` (imported here, when a
    worker runs a source, so that importing this module stays light)."""
    from .detection_outputs import DetectionLines, TypedDetections
    from .outputs import default_topic

    if fmt == "jsonl":
        return DetectionLines(path)
    if fmt == "mcap":
        return TypedDetections(path, array_type, topic or default_topic(object_name))
    raise ValueError(f"unknown output format {fmt!r} (formats: {', '.join(FORMATS)})")


def run_source(
    params: str,
    spec: str,
    output: str,
    fmt: str = "jsonl",
    max_frames: int | None = None,
    topic: str | None = None,
    frame_id: str = "camera",
    stop_event: str | None = None,
    starts_queue: str | None = None,
) -> SourceResult:
    """Run the parameter file's system over one source into ``output``; never raises for a bad source.

    Everything a source can throw is caught, whatever library it comes from (a corrupt recording fails in
    FFmpeg, a bag reader or a decoder, each in its own way): the batch must go on with the others, and the
    summary says what went wrong in one line. The output is opened first, so every source has its file, and
    a recording that breaks half way keeps the detections of the frames before the break.

    ``stop_event`` names the Dask Event the batch sets when interrupted: the source then ends after the frame
    in hand (status "stopped", its output closed properly), or is not started at all ("cancelled").
    ``starts_queue`` names the Dask queue that counts each start of a source (a worker that died under it).
    """
    _worker_logging()
    result = SourceResult(spec, Path(output).name)
    director: DetectionDirector | None = None
    stop = _StopFlag(stop_event) if stop_event else None
    if stop is not None and stop.is_set():
        result.status = CANCELLED
        return result
    if starts_queue:
        _note_start(starts_queue, result.output)
    try:
        system = build_system(params)
        detections: Output | None = None
        end = RunEnd(Ending.FAILED)  # an output keeps the frames done before a break, an MCAP file is completed
        try:
            detections = _open_output(Path(output), fmt, system.object_array_type, topic, system.object_name)
            director = DetectionDirector(system, frame_id=frame_id)
            detections.attach(director)
            with open_source(spec, system.kind) as source:
                director.run_all(source, max_frames, stop=stop)  # type: ignore[arg-type] - has is_set()
            end = RunEnd(Ending.COMPLETED)
            if director.stats.stopped_by == "stop":
                result.status = STOPPED
                end = RunEnd(Ending.INTERRUPTED)
        finally:
            if detections is not None:
                detections.close(end)
    except Exception as exc:  # see the docstring: one source's failure of any kind is a row, not a crash
        log.debug("%s failed", spec, exc_info=True)
        result.status = f"{FAILED}: {one_line(exc)}"
    stats = director.stats if director is not None else RunStats()
    result.frames, result.objects = stats.frames, stats.objects
    result.frames_with_objects, result.seconds = stats.frames_with_objects, stats.seconds
    return result
