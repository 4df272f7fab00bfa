"""objrec-batch: run one parameter file's system over many recordings in parallel on Dask.

Each source goes to a worker as a path (with the parameter file's path, never file contents); the worker
builds the system itself and writes one output per source into the output folder. A local cluster of worker
processes is started by default, or the work goes to an existing Dask scheduler. The summary (one row per
source) is printed and written as ``summary.csv``; a source that fails is a row saying why, never the end
of the batch.

Exit codes: 0 every source done; 1 some source failed (its row says why); 2 a user mistake (bad parameter
file, option out of its range, output folder, no sources, unreachable scheduler, a bad OBJREC_MAX_* variable)
or a summary that cannot be written; 130 interrupted (Ctrl-C or SIGTERM: running sources stop after their
current frame, the others are cancelled, and the summary so far is written).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import gc
import io
import logging
import os
import signal
import sys
import tempfile
import time
import uuid
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from objrec_core import (
    DetectionDirector,
    ParameterFileError,
    PipelineError,
    SourceError,
    SourceSpec,
    UnknownModuleError,
    get_kind,
    source_schemes,
)
from strictio import InputError, OutputError, write_atomically
from strictio.cli_numbers import CommandLineParser, Number
from strictio.output_paths import RunFiles
from strictio.shown import escape_controls, printable
from strictio.signals import handling, raise_interrupt

from .batch_worker import (
    CANCELLED,
    FAILED,
    FORMATS,
    STOPPED,
    SourceResult,
    count_kept_lines,
    one_line,
    output_names,
    run_source,
    worker_deaths,
)
from .cli import (
    INTERRUPTED,
    MAX_FRAMES,
    MESSAGE_LIMIT,
    USER_ERROR,
    UserError,
    detecting_system,
    parse_and_run,
    quiet_stdout,
    report,
    run_command,
)
from .launch import ending_at_once
from .outputs import check_topic, default_topic, open_typed_writer, require_rosbags
from .scheduler_probe import DEFAULT_TIMEOUT, SchedulerUnusable, probe

log = logging.getLogger("objrec.batch")
PROG = "objrec-batch"

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_INTERRUPTED = INTERRUPTED
SUMMARY = "summary.csv"
SUMMARY_FIELDS = ("source", "output", "frames", "frames_with_objects", "objects", "frames_per_s", "seconds", "status",
                  "runs")
#: Worker processes each get one core: libraries' own thread pools would otherwise oversubscribe the machine
#: (Dask already sets OMP/MKL/OpenBLAS to one thread; OpenCV's pthreads pool reads this one).
WORKER_ENV = {"OPENCV_FOR_THREADS_NUM": "1"}
#: The status of a source still running (or queued) when the batch gave up waiting after Ctrl-C.
ABANDONED = "abandoned"
#: Retries of a source whose worker process died under it (local cluster): each worker runs one source at a
#: time, so a second death is the source's doing (a decoder crashing on it), not bad luck.
ALLOWED_FAILURES = 1
#: How long running sources get to stop after Ctrl-C before they are abandoned.
STOP_SECONDS = 20.0
#: How long an existing scheduler gets to accept the connection, and again to answer it (--scheduler-timeout).
SCHEDULER_TIMEOUT = Number(0.1, 600.0)
#: Worker processes of a local cluster: each is a whole interpreter with the libraries loaded.
WORKERS = Number(1, 256, whole=True)


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLineParser(
        prog=PROG,
        description="Run a parameter file's system over many sources in parallel on Dask: one output per\n"
        "source in DIR, and a summary table (on stdout and as DIR/summary.csv).",
        epilog="""\
sources:
  any the parameter file's kind reads: videos, image folders, cloud files, ROS bags
  and MCAP files, scheme:key=value specs. Workers get paths, never contents: with
  --scheduler every worker must see the same paths and DIR (plain paths are made
  absolute; paths inside scheme: specs are read as given).

exit codes:
  0    every source done
  1    some source failed (its status in the summary says why); the others ran
  2    a user mistake (parameter file, option, output folder, scheduler address)
  130  interrupted by Ctrl-C or SIGTERM: running sources stop after their frame
       ("stopped"), the rest are "cancelled" (a second Ctrl-C "abandoned"s the
       running ones), and the summary so far is still written
""",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("params", metavar="PARAMS_FILE", help="parameter file (YAML) of a recognition system")
    parser.add_argument("sources", metavar="SOURCE", nargs="+", help="recordings to run the system over")
    parser.add_argument("--out", "-o", metavar="DIR", required=True,
                        help="folder for the outputs (<source name>.jsonl or .mcap) and summary.csv; made if missing")
    parser.add_argument("--workers", "-w", type=WORKERS, metavar="N",
                        help="worker processes of the local cluster, one thread each "
                        f"(default: the cores available, {default_workers()} here, at most one per source; "
                        f"{WORKERS.describe()})")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on an existing Dask scheduler (tcp://host:8786) instead of a local cluster")
    parser.add_argument("--scheduler-timeout", type=SCHEDULER_TIMEOUT, default=DEFAULT_TIMEOUT, metavar="SECONDS",
                        help=f"how long the scheduler gets to accept the connection and to answer it (default "
                        f"{DEFAULT_TIMEOUT:g}; {SCHEDULER_TIMEOUT.describe()})")
    parser.add_argument("--format", "-f", choices=tuple(FORMATS), default="jsonl",
                        help="output format: JSON Lines (default) or MCAP typed messages (needs the ros extra)")
    parser.add_argument("--max-frames", "-n", type=MAX_FRAMES, metavar="N",
                        help=f"at most N frames of each source ({MAX_FRAMES.describe()})")
    parser.add_argument("--output-topic", metavar="TOPIC",
                        help="topic of the MCAP messages (default: /objrec/<object name>)")
    parser.add_argument("--frame-id", default="camera",
                        help="frame_id written in headers when the source gives none (default: camera)")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                        help="progress bar over sources on stderr (default: on a terminal)")
    parser.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    return parser


# -- what to run -----------------------------------------------------------------------------------------------
@dataclass
class Plan:
    """A checked batch: absolute paths for workers, one output name per source."""

    params: str
    specs: list[str]  # as the user gave them (the summary shows these)
    worker_specs: list[str]  # what workers open: plain paths made absolute
    out_dir: Path
    outputs: list[str]  # file names in out_dir
    fmt: str = "jsonl"
    max_frames: int | None = None
    topic: str | None = None
    frame_id: str = "camera"
    object_name: str = "object"
    #: The system's detection message type: a never-started source's (empty) MCAP output declares its channel.
    array_type: Any = None


def _absolute_spec(spec: str, schemes: set[str]) -> str:
    """A plain path made absolute, so that a worker in another folder finds it; scheme specs as given."""
    parsed = SourceSpec.parse(spec, schemes)
    return os.path.abspath(parsed.path) if parsed.path is not None else spec


def _check_out_dir(path: str) -> Path:
    out = Path(path).expanduser()
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except FileExistsError:
        raise UserError(f"{path}: exists and is not a folder") from None
    except OSError as exc:
        raise UserError(f"{path}: output folder cannot be written: {exc.strerror or exc}") from None
    return out.absolute()


def make_plan(params: str, specs: Sequence[str], out: str, fmt: str = "jsonl", max_frames: int | None = None,
              topic: str | None = None, frame_id: str = "camera") -> Plan:
    """Check everything that is the user's to get right before any worker starts; UserError otherwise.

    The sources themselves are not opened here: reading them is the workers' job, and one bad recording
    among hundreds is a row in the summary, not a reason to refuse the batch.
    """
    if not specs:
        raise UserError("no sources given")
    if fmt not in FORMATS:
        raise UserError(f"--format {fmt}: unknown (formats: {', '.join(FORMATS)})")
    if max_frames is not None and max_frames < 1:
        raise UserError(f"--max-frames must be at least 1, got {max_frames}")
    try:
        system = detecting_system(params)
        get_kind(system.kind)
        not_ready = DetectionDirector(system).not_ready()  # e.g. a feature file saved before any selection
        if not_ready:
            raise UserError(f"{params}: " + "; ".join(not_ready))
    except (ParameterFileError, UnknownModuleError, PipelineError) as exc:
        raise UserError(str(exc)) from None
    if fmt == "mcap":
        require_rosbags("--format mcap")
        topic = check_topic(topic) if topic else default_topic(system.object_name)
    elif topic:
        raise UserError("--output-topic is for --format mcap (JSON Lines have no topics)")
    try:
        schemes = source_schemes()
        worker_specs = [_absolute_spec(s, schemes) for s in specs]
        outputs = output_names(specs, FORMATS[fmt], schemes)
    except SourceError as exc:
        raise UserError(str(exc)) from None
    _check_outputs(params, specs, worker_specs, out, outputs, FORMATS[fmt], schemes)
    return Plan(os.path.abspath(params), list(specs), worker_specs, _check_out_dir(out), outputs, fmt, max_frames,
                topic, frame_id, system.object_name, system.object_array_type)


def _check_outputs(params: str, specs: Sequence[str], worker_specs: Sequence[str], out: str, outputs: Sequence[str],
                   suffix: str, schemes: set[str]) -> None:
    """The output rule of every command (strictio.output_paths), before anything is made: no output of a source
    is an input (``--format mcap`` into the folder of the source ``.mcap``), a link out of ``--out`` (which
    would truncate a file elsewhere), read-only (refused as root too) or a FIFO; OutputError naming it."""
    files = RunFiles().reads(params, "the parameter file")
    for spec, worker_spec in zip(specs, worker_specs, strict=True):
        path = SourceSpec.parse(worker_spec, schemes).path
        files.reads(path, f"the source {spec}")
    folder = Path(out).expanduser()
    if not folder.is_dir() and not folder.parent.is_dir():
        return  # nothing there yet to protect: _check_out_dir says why the folder cannot be made, or makes it
    if folder.exists() and not folder.is_dir():
        return  # a file where the folder should be: _check_out_dir's own message
    files.writes("--out", folder, folder=True, names=f"*{suffix}")
    for spec, name in zip(specs, outputs, strict=True):
        files.writes(f"the output of {spec}", folder / name, inside=folder, stream=suffix == ".jsonl")
    files.writes("the summary", folder / SUMMARY, inside=folder)


# -- running it on Dask ----------------------------------------------------------------------------------------
@dataclass
class BatchOutcome:
    """Every source's row, in the order given, and how the batch as a whole went."""

    results: list[SourceResult]
    seconds: float = 0.0  # the whole batch, the cluster's start and close included
    work_seconds: float = 0.0  # from the first source handed out to the last row back
    workers: int = 0
    interrupted: bool = False
    notes: list[str] = field(default_factory=list)

    @property
    def failed(self) -> list[SourceResult]:
        return [r for r in self.results if r.status.startswith(FAILED)]


def _quiet_dask() -> None:
    """Dask logs every start and stop at INFO; only its warnings belong on our stderr. The environment variable
    reaches the local workers too (they read Dask's configuration when they start)."""
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")
    logging.getLogger("distributed").setLevel(logging.WARNING)
    for name in ("distributed.nanny", "distributed.scheduler"):
        logger = logging.getLogger(name)
        if not any(isinstance(f, _SaidInTheSummary) for f in logger.filters):
            logger.addFilter(_SaidInTheSummary())


class _SaidInTheSummary(logging.Filter):
    """Drops Dask's own lines about a worker process that died (the nanny restarting it, the scheduler giving
    up on a task): the source's row and its error line say it, naming the source."""

    def filter(self, record: logging.LogRecord) -> bool:
        text = str(record.msg)
        return not (text.startswith("Restarting worker") or "workers died while trying to run it" in text
                    or "marked as failed because" in text)


def _size(spec: str) -> int:
    """Bytes of a source on disk (a folder's files summed), to start the longest first; 0 when unknown."""
    path = Path(spec)
    with contextlib.suppress(OSError):
        if path.is_dir():
            return sum(p.stat().st_size for p in path.iterdir() if p.is_file())
        return path.stat().st_size
    return 0


def _workers_ignore_ctrl_c() -> contextlib.AbstractContextManager[None]:
    """Start worker processes with SIGINT ignored (a disposition they inherit): Ctrl-C in a terminal reaches
    the whole process group, and only this process should act on it, by cancelling and closing the cluster,
    instead of every worker dying with its own traceback."""
    return handling(signal.SIG_IGN, (signal.SIGINT,))


def _quiet_worker_shutdown() -> None:
    """Runs on each worker after Ctrl-C: closing a worker with a task still running logs a warning per task,
    which says nothing the summary does not."""
    logging.getLogger("distributed.worker").setLevel(logging.ERROR)


def _check_address(address: str) -> tuple[str, str]:
    """A scheduler address Dask can parse, as (scheme, location), refused before connecting (a client failing
    on a malformed address hangs on its way out)."""
    from distributed.comm.addressing import parse_address
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(address)
        get_backend(scheme)
    except (ValueError, TypeError) as exc:
        raise UserError(f"--scheduler {address}: not a scheduler address: {' '.join(str(exc).split())}") from None
    if not location.strip():
        raise UserError(f"--scheduler {address}: not a scheduler address: no host (e.g. tcp://host:8786)")
    if scheme == "inproc":
        raise UserError(f"--scheduler {address}: an inproc address is only reachable inside its own process")
    return scheme, location


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int, timeout: float = DEFAULT_TIMEOUT) -> Iterator[tuple[Any, int]]:
    """A Dask client on a new local cluster or an existing scheduler, and its workers, closed (cluster and all)
    on the way out; Dask's scratch space is the batch's own and goes with it."""
    _quiet_dask()
    from distributed import Client, LocalCluster

    cluster = None
    with _scratch_space() as scratch:
        if scheduler:
            client = _connect(scheduler, timeout)
        else:
            with _workers_ignore_ctrl_c():
                # No dashboard; the scheduler's small HTTP server (health, metrics) on a free local port, so
                # that another cluster on 8787 costs no warning. Workers spill and lock in our scratch folder.
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None, local_directory=scratch,
                                       scheduler_kwargs={"dashboard_address": "127.0.0.1:0",
                                                         "allowed_failures": ALLOWED_FAILURES},
                                       silence_logs=logging.WARNING, env=WORKER_ENV)
            client = Client(cluster, set_as_default=False)
        try:
            count = len(client.scheduler_info().get("workers", {})) if scheduler else workers
            yield client, count
        finally:
            with contextlib.suppress(Exception):  # closing after a Ctrl-C may find connections already gone
                client.close()
            if cluster is not None:
                with contextlib.suppress(Exception):
                    cluster.close()


@contextlib.contextmanager
def _scratch_space() -> Iterator[str]:
    """A temporary folder of this batch for Dask's scratch space and its lock files (``dask-scratch-space/``,
    ``global.lock``, ``purge.lock``), removed with everything in it when the batch ends: Dask's own default
    is a shared folder in the temp folder that every run left behind."""
    import dask

    # A worker holds only the source it runs (saturation 1.0, Dask's default queues a second one on it): a
    # worker that dies takes no queued source down with it, to fail later as if it had crashed it.
    with tempfile.TemporaryDirectory(prefix="objrec-batch-") as scratch, \
            dask.config.set({"temporary-directory": scratch, "distributed.scheduler.worker-saturation": 1.0}):
        yield scratch


def _connect(scheduler: str, timeout: float) -> Any:
    """A client of an existing scheduler, or a UserError saying why not, within about ``timeout`` seconds: the
    address is probed first (:mod:`.scheduler_probe`: refused, silent, another protocol, another user's),
    then Dask's client gets the same deadline for its own connection."""
    from distributed import Client

    scheme, location = _check_address(scheduler)
    try:
        probe(scheduler, scheme, location, timeout)
    except SchedulerUnusable as exc:
        raise UserError(f"--scheduler {scheduler}: cannot use it: {exc}") from None
    failure = ""
    try:
        client = Client(scheduler, timeout=f"{timeout}s", set_as_default=False)
    except (OSError, ValueError, TypeError, MemoryError) as exc:
        failure = " ".join(str(exc).split()) or type(exc).__name__
    if failure:
        # Outside the except block, so that the half-made client (held by the traceback) is collected now,
        # while its event loop still runs; at interpreter exit its close would hang for a minute.
        gc.collect()
        raise UserError(f"--scheduler {scheduler}: cannot connect: {failure}")
    info = client.scheduler_info()
    log.info("joined scheduler %s at %s (%d workers)", info.get("id", "?"), info.get("address", scheduler),
             len(info.get("workers", {})))
    return client


def _worker_deaths(client: Any, key: str) -> int:
    """How many worker processes died while the scheduler had given them the task ``key`` (Dask's count of
    "suspicious" deaths); 0 when the scheduler cannot be asked (a remote one without objrec)."""
    try:
        return int(client.run_on_scheduler(worker_deaths, key))
    except Exception:  # the count is a note in the summary, never a reason to lose a row
        return 0


def _killed_status(output: Path, plan: Plan, runs: int, deaths: int) -> str:
    """The status of a source whose worker processes kept dying: run (``runs`` times; its output is kept, with
    the frames written before the last death) or never started (the deaths were another source's, with it
    queued on the same worker); a source that never started gets an empty output (JSON Lines, or an MCAP file
    with its channel and no message), as every failed source has one."""
    times = "twice" if deaths == 2 else f"{deaths} times" if deaths > 2 else "again"
    if runs:
        kept = (f"; {output.name} keeps the frames done before" if output.exists()
                else f"; no {output.name}: a typed output is written whole or not at all")
        return (f"{FAILED}: its worker process died running it, {'twice' if runs == 2 else f'{runs} times'} (a "
                f"crash in a library reading it, or out of memory){kept}")
    if plan.fmt == "jsonl":
        with contextlib.suppress(OSError):
            output.touch(exist_ok=True)
    elif plan.array_type is not None and plan.topic and not output.exists():
        try:
            open_typed_writer(str(output), plan.array_type, plan.topic).close()
        except (OSError, OutputError) as exc:
            log.warning("cannot write the empty %s: %s", output, exc)
    return (f"{FAILED}: never started: the worker processes given it died {times}, running other sources "
            "(a crash in a library, or out of memory)")


class _Starts:
    """How many times each source was started: every run of a source puts its output name in a Dask queue of
    this batch as it starts (:func:`.batch_worker.run_source`), so a source run again after its worker died
    says so in the summary, and one that never started is told from one that crashed."""

    def __init__(self, client: Any, name: str) -> None:
        from distributed import Queue

        self.name = name
        self._queue = Queue(name, client=client)
        self._counts: dict[str, int] = {}

    def of(self, output: str) -> int:
        """The starts of the source writing ``output`` so far (0 when the queue cannot be read)."""
        try:
            for started in self._queue.get(batch=True):
                self._counts[started] = self._counts.get(started, 0) + 1
        except Exception:  # a count for the summary, never a reason to lose a row
            log.debug("cannot read the start queue", exc_info=True)
        return self._counts.get(output, 0)


class _Bar:
    """A tqdm bar over sources on stderr; failures are written above it so they stay readable."""

    def __init__(self, total: int, enabled: bool | None) -> None:
        from tqdm import tqdm

        self._bar = tqdm(total=total, unit="source", file=sys.stderr, disable=None if enabled is None else not enabled,
                         dynamic_ncols=True)

    def done(self, result: SourceResult) -> None:
        if result.status.startswith(FAILED):
            named = result.source in result.status or Path(result.source).name in result.status
            shown = printable(f"{'' if named else result.source + ': '}{result.status}", limit=MESSAGE_LIMIT)
            self._bar.write(f"{PROG}: {shown}", file=sys.stderr)
        self._bar.update(1)

    def write(self, message: str) -> None:
        self._bar.write(message, file=sys.stderr)

    def close(self) -> None:
        self._bar.close()


def run_batch(plan: Plan, workers: int | None = None, scheduler: str | None = None,
              progress: bool | None = False, timeout: float = DEFAULT_TIMEOUT) -> BatchOutcome:
    """Run every source of ``plan`` on Dask and collect the rows, in the order the sources were given.

    Ctrl-C (KeyboardInterrupt, SIGTERM in the command) asks the running sources to stop after their current
    frame, so their outputs end cleanly and their rows count what was done; sources not started are
    cancelled. A second Ctrl-C, or STOP_SECONDS without an answer, abandons the running ones too.
    """
    results = [SourceResult(spec, name, status=CANCELLED) for spec, name in zip(plan.specs, plan.outputs, strict=True)]
    outcome = BatchOutcome(results)
    if scheduler and workers is not None:
        outcome.notes.append("--workers is ignored with --scheduler: the scheduler's workers run the sources")
    workers = min(workers or default_workers(), len(plan.specs))
    start = time.perf_counter()
    with _client(scheduler, workers, timeout) as (client, count):
        outcome.workers = count
        if scheduler and count == 0:
            outcome.notes.append(f"{scheduler} has no workers yet; the sources wait for some to join")
        for note in outcome.notes:
            log.warning("%s", note)
        from distributed import Event, as_completed
        from distributed.scheduler import KilledWorker

        batch_id = uuid.uuid4().hex
        stop = Event(f"objrec-batch-stop-{batch_id}", client=client)
        starts = _Starts(client, f"objrec-batch-starts-{batch_id}")
        work_start = time.perf_counter()
        index = {}
        for i, (spec, name) in enumerate(zip(plan.worker_specs, plan.outputs, strict=True)):
            future = client.submit(
                run_source, plan.params, spec, str(plan.out_dir / name), plan.fmt, plan.max_frames, plan.topic,
                plan.frame_id, stop.name, starts.name, key=f"objrec-batch-{i}-{name}", pure=False, retries=0,
                priority=_size(spec),
            )
            index[future] = i
        bar = _Bar(len(index), progress)
        pending = set(index)

        def collect(timeout: float | None = None) -> None:
            for future in as_completed(list(pending), loop=client.loop, timeout=timeout):
                pending.discard(future)
                i = index[future]
                try:
                    results[i] = future.result()
                    results[i].source = plan.specs[i]  # as the user named it (the worker had it absolute)
                    results[i].runs = max(1, starts.of(plan.outputs[i]))
                except KilledWorker:
                    results[i].runs = starts.of(plan.outputs[i])
                    results[i].status = _killed_status(plan.out_dir / plan.outputs[i], plan, results[i].runs,
                                                       _worker_deaths(client, future.key))
                    if results[i].runs and plan.fmt == "jsonl":  # what the kept file holds, not 0 frames
                        count_kept_lines(results[i], plan.out_dir / plan.outputs[i])
                except Exception as exc:  # the task could not run at all (objrec missing on a remote worker)
                    results[i].status = f"{FAILED}: {one_line(exc)}"
                # Let the worker forget the row: a worker that dies later would otherwise make the scheduler
                # run this source again to recompute a result nobody needs any more.
                future.release()
                bar.done(results[i])

        try:
            try:
                collect()
            except KeyboardInterrupt:
                outcome.interrupted = True
                bar.write(f"{PROG}: interrupted: stopping the running sources (Ctrl-C again to abandon them)")
                try:
                    stop.set()
                    collect(STOP_SECONDS)
                except (KeyboardInterrupt, Exception):  # a second Ctrl-C, or workers that did not answer in time
                    pass
                for future in pending:  # running or queued still: an output may be there, incomplete
                    results[index[future]].status = ABANDONED
                if pending:
                    with contextlib.suppress(Exception):
                        client.cancel(list(pending))
                        if not scheduler:  # our own workers, about to be closed under a running task
                            client.run(_quiet_worker_shutdown)
        finally:
            outcome.work_seconds = time.perf_counter() - work_start
            bar.close()
    outcome.seconds = time.perf_counter() - start
    return outcome


# -- the summary -------------------------------------------------------------------------------------------------
TABLE_HEADINGS = ("source", "output", "frames", "with objects", "objects", "frames/s", "status")


def format_table(results: Sequence[SourceResult]) -> str:
    """The summary as an aligned text table (numbers right-aligned); names shown escaped (a control character
    or a byte that is not UTF-8 in a file name can neither break a row nor reach the terminal raw)."""
    rows = [TABLE_HEADINGS] + [
        (escape_controls(r.source), escape_controls(r.output), str(r.frames), str(r.frames_with_objects),
         str(r.objects), f"{r.rate:.1f}", escape_controls(r.shown_status))
        for r in results
    ]
    widths = [max(len(row[c]) for row in rows) for c in range(len(TABLE_HEADINGS))]
    numeric = {2, 3, 4, 5}
    lines = []
    for row in rows:
        cells = [cell.rjust(widths[c]) if c in numeric else cell.ljust(widths[c]) for c, cell in enumerate(row)]
        lines.append("  ".join(cells).rstrip())
    return "\n".join(lines) + "\n"


def summary_csv(results: Sequence[SourceResult]) -> str:
    stream = io.StringIO()
    writer = csv.DictWriter(stream, SUMMARY_FIELDS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for result in results:
        writer.writerow(result.to_row())
    return stream.getvalue()


def totals_line(outcome: BatchOutcome) -> str:
    results = outcome.results
    frames = sum(r.frames for r in results)
    objects = sum(r.objects for r in results)
    rate = frames / outcome.work_seconds if outcome.work_seconds > 0 else 0.0
    parts = [f"{len(results)} source{'s' if len(results) != 1 else ''}", f"{len(outcome.failed)} failed"]
    for status in (STOPPED, CANCELLED, ABANDONED):
        count = sum(r.status == status for r in results)
        if count:
            parts.append(f"{count} {status}")
    workers = f"{outcome.workers} worker{'s' if outcome.workers != 1 else ''}"
    return (f"{PROG}: {', '.join(parts)}; {frames} frames, {objects} objects in {outcome.seconds:.1f} s "
            f"({outcome.work_seconds:.1f} s on {workers} after the cluster started: {rate:.1f} frames/s)")


# -- the command ----------------------------------------------------------------------------------------------
def run(args: argparse.Namespace, stdout: IO[str]) -> int:
    with ending_at_once(PROG):  # before a worker starts nothing runs or is written: a signal ends it at once
        plan = make_plan(args.params, args.sources, args.out, args.format, args.max_frames, args.output_topic,
                         args.frame_id)
    try:
        with handling(raise_interrupt, (signal.SIGTERM,)):  # SIGTERM as Ctrl-C: cancel what is left, still summarize
            outcome = run_batch(plan, args.workers, args.scheduler, args.progress, args.scheduler_timeout)
    except KeyboardInterrupt:  # while the cluster was starting: nothing ran
        outcome = BatchOutcome([SourceResult(s, n, status=CANCELLED) for s, n in zip(plan.specs, plan.outputs,
                                                                                        strict=True)],
                               interrupted=True)
    code = EXIT_INTERRUPTED if outcome.interrupted else EXIT_FAILED if outcome.failed else EXIT_OK
    try:
        write_atomically(plan.out_dir / SUMMARY, summary_csv(outcome.results))
    except OutputError as exc:
        report(PROG, exc)
        code = USER_ERROR if code != EXIT_INTERRUPTED else code
    try:
        stdout.write(format_table(outcome.results))
        stdout.flush()
    except BrokenPipeError:  # the reader went away (`| head`): the summary file has it all
        quiet_stdout(stdout)
    sys.stderr.write(totals_line(outcome) + (" (interrupted)" if outcome.interrupted else "") + "\n")
    return code


def main(argv: list[str] | None = None) -> int:
    return run_command(PROG, lambda: parse_and_run(PROG, build_parser(), argv, run),
                       mistakes=(UserError, InputError, OutputError), interrupted="interrupted while starting")


if __name__ == "__main__":
    sys.exit(main())
