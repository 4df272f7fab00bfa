"""objrec-detect: run any parameter file headless and stream the detected objects as JSON Lines, or write
them as typed ROS messages into an MCAP file, a ROS 1 bag or a ROS 2 bag folder (``--output``).

Exit codes: 0 done (also after Ctrl-C or SIGTERM, with everything written so far flushed and a typed
output completed); 1 a source that breaks mid-stream; 2 a user mistake (bad parameter file, option out of
its range, a source that cannot be opened or yields not even one frame, an input refused anywhere in the run
such as a frame over a declared limit, a detector that cannot detect, such as a feature detector without a
target) and any output that cannot be written (a full disk, a closed device; a typed output that cannot be
written is left out entirely, what the other outputs got so far is kept); 130 interrupted while starting.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType
from typing import IO, Any

from objrec_core import (
    DetectedObjectArray,
    DetectionDirector,
    Frame,
    FrameSource,
    JSONLinesSink,
    Kind,
    ParameterFileError,
    PipelineError,
    SourceError,
    Stage,
    UnknownModuleError,
    build_system,
    get_kind,
    open_source,
)
from rerunio import RerunUnavailable
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, check_limit_settings

from . import explain, outputs
from .annotation_writer import AnnotationError, AnnotationWriter
from .cli import MAX_FRAMES, USER_ERROR, UserError, configure_logging, open_text_output, report
from .rerun_log import open_rerun

log = logging.getLogger("objrec.detect")
PROG = "objrec-detect"
#: Exit code after Ctrl-C before the run loop took over.
INTERRUPTED = 130


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLineParser(
        prog=PROG,
        description="Detect objects with a parameter file made by objrec-define; one JSON line per frame, or "
        "typed ROS messages in an MCAP file or a bag.",
        epilog="Sources: a path (image, video, folder, cloud file, .bag, .mcap, ROS 2 bag folder) or "
        "scheme:key=value,... such as demo, demo:seed=3,frames=100, camera:0, rgbd:COLOR,DEPTH, "
        "bag:PATH,topic=NAME. The parameter file's kind decides which are read.",
    )
    parser.add_argument("params", metavar="PARAMS_FILE", nargs="?",
                        help="parameter file (YAML) of a recognition system")
    parser.add_argument("--source", "-s", help="demo, demo:seed=N,frames=N, camera:N, bag:PATH, or a path")
    parser.add_argument(
        "--output", "-o", metavar="PATH",
        help="where the detections go instead of stdout: FILE.mcap (MCAP), FILE.bag (ROS 1 bag) or a folder "
        "(ROS 2 bag, MCAP storage) get typed ROS messages (needs objrec[ros]); any other file JSON lines",
    )
    parser.add_argument("--output-topic", metavar="TOPIC",
                        help="topic of the typed messages (default: /objrec/<object name>)")
    parser.add_argument("--copy-input", action="store_true",
                        help="with a bag source and a typed output: copy the topics it reads too (a depth "
                        "topic with its CameraInfo and colour topics), so the output replays with its detections")
    parser.add_argument("--list-topics", metavar="SOURCE",
                        help="print the topics, types and message counts of a bag or MCAP file, and exit")
    parser.add_argument("--max-frames", "-n", type=MAX_FRAMES, metavar="N",
                        help=f"stop after N frames ({MAX_FRAMES.describe()})")
    parser.add_argument("--frame-id", default="camera",
                        help="frame_id written in headers when the source gives none (default: camera)")
    parser.add_argument(
        "--rerun", metavar="FILE.rrd|spawn",
        help="also log every frame, stage and detection to a Rerun recording (needs objrec[viz])",
    )
    parser.add_argument(
        "--annotate", metavar="PATH", help="also write pictures: a video (.avi/.mp4) or a folder of PNGs"
    )
    parser.add_argument(
        "--annotate-view",
        choices=("objects", "debug"),
        default="objects",
        help="objects: detections drawn on the original frame; debug: the detector's own view (e.g. matches)",
    )
    parser.add_argument("--skip-empty", action="store_true", help="write no line for frames with no object")
    parser.add_argument(explain.OPTION, metavar="PATH", nargs="?", const=explain.STDERR, help=explain.HELP)
    parser.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar (default: on a terminal)"
    )
    parser.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    return parser


class _Stopper:
    """Turns SIGTERM and Ctrl-C into a stop request, so the loop ends between frames and flushes."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self.reason = ""

    def __call__(self, signum: int, _frame: FrameType | None) -> None:
        if signum == signal.SIGINT and self.event.is_set():
            raise KeyboardInterrupt  # a second Ctrl-C: the source itself may be stuck
        self.reason = signal.Signals(signum).name
        self.event.set()


class BarProgress:
    """The run loop's progress as a tqdm bar on stderr (only where the total is known)."""

    def __init__(self, enabled: bool | None) -> None:
        self.enabled = enabled
        self._bar: Any = None

    def start(self, total: int | None) -> None:
        if total is None or self.enabled is False:
            return
        from tqdm import tqdm

        self._bar = tqdm(total=total, unit="frame", file=sys.stderr, disable=None if self.enabled is None else False)

    def advance(self, frames: int = 1) -> None:
        if self._bar is not None:
            self._bar.update(frames)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


class PictureSink:
    """Writes each frame's picture: the kind's annotation, or with ``debug`` the first detector's own view."""

    def __init__(self, writer: AnnotationWriter, kind: Kind, debug: bool) -> None:
        self.writer, self.kind, self.debug = writer, kind, debug

    def __call__(self, frame: Frame, objects: DetectedObjectArray, stages: Sequence[Stage] | None) -> None:
        picture = None
        if self.debug and stages:
            picture = next((s.debug for s in stages if s.debug is not None), None)
            if isinstance(picture, dict):
                picture = next(iter(picture.values()), None)
        self.writer.write(picture if picture is not None else self.kind.annotate(frame, objects))


def _open(args: argparse.Namespace) -> tuple[DetectionDirector, FrameSource, Kind]:
    try:
        system = build_system(args.params)
    except ParameterFileError as exc:
        raise UserError(str(exc)) from None
    if not system.detectors:
        raise UserError(f"{args.params}: pipeline: has no detector, so nothing would be detected")
    director = DetectionDirector(system, frame_id=args.frame_id)
    not_ready = director.not_ready()
    if not_ready:
        raise UserError(f"{args.params}: " + "; ".join(not_ready))
    try:
        kind = get_kind(system.kind) if system.kind else None
        if kind is None:
            raise UserError(f"{args.params}: kind: no module declares its data kind")
        source = open_source(args.source, kind.name)
    except (SourceError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None
    return director, source, kind


def _check_output_options(args: argparse.Namespace) -> None:
    """The output options that can be judged before anything is opened."""
    if args.output and outputs.is_typed_output(args.output):
        outputs.require_rosbags(f"--output {args.output}")
        if args.output_topic:
            args.output_topic = outputs.check_topic(args.output_topic)
        return
    for option, given in (("--output-topic", args.output_topic), ("--copy-input", args.copy_input)):
        if given:
            raise UserError(f"{option} needs a typed --output (FILE.mcap, FILE.bag or a ROS 2 bag folder)")


def _typed_writer(args: argparse.Namespace, director: DetectionDirector, source: FrameSource) -> Any:
    """The typed-message writer ``--output`` asks for, or None for JSON Lines."""
    if not (args.output and outputs.is_typed_output(args.output)):
        return None
    system = director.system
    topic = args.output_topic or outputs.default_topic(system.object_name)
    copy = outputs.input_copy(source) if args.copy_input else None
    return outputs.open_typed_writer(args.output, system.object_array_type, topic, copy)


def _skipping_empty(sink: Any) -> Any:
    def write(array: DetectedObjectArray) -> None:
        if array.objects:
            sink(array)

    return write


def _list_topics(args: argparse.Namespace, stdout: IO[str]) -> int:
    outputs.require_rosbags("--list-topics")
    from objrec_ros.bags import list_topics

    try:
        text = list_topics(outputs.recording_path(args.list_topics))
    except SourceError as exc:
        raise UserError(str(exc)) from None
    stdout.write(text + "\n")
    return 0


def _check_explain(args: argparse.Namespace) -> None:
    if args.explain == "":
        raise UserError("--explain=: give a path after the =, or --explain alone for the reasons on stderr")
    if args.explain in (None, explain.STDERR) or not args.output:
        return
    if Path(args.explain).resolve() == Path(args.output).resolve():
        raise UserError(f"--explain={args.explain}: the same file as --output; give the reasons a file of their own")


def run(args: argparse.Namespace, stdout: IO[str]) -> int:
    if args.list_topics:
        return _list_topics(args, stdout)
    _check_output_options(args)
    _check_explain(args)
    director, source, kind = _open(args)
    stopper = _Stopper()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous = {sig: signal.signal(sig, stopper) for sig in (signal.SIGTERM, signal.SIGINT)}
    writer = None
    output = None
    typed = None
    recorder = None
    reasons = None
    status = 0
    keep_typed = True  # a typed output is completed with what it got, unless it failed itself or got nothing
    try:
        if args.explain is not None:
            reasons = explain.Explainer(args.explain)
            director.add_outcome_sink(reasons.sink)
        if args.rerun:
            try:
                recorder = open_rerun(args.rerun, kind, director.system)
            except RerunUnavailable as exc:
                raise UserError(str(exc)) from None
            director.keep_stages = True
            director.add_annotation_sink(recorder)
        typed = _typed_writer(args, director, source)
        if typed is not None:
            director.add_sink(_skipping_empty(typed) if args.skip_empty else typed)
        else:
            output = open_text_output(args.output) if args.output else None
            director.add_sink(JSONLinesSink(output or stdout, skip_empty=args.skip_empty))
        if args.annotate:
            try:
                writer = AnnotationWriter(args.annotate)
            except AnnotationError as exc:
                raise UserError(str(exc)) from None
            debug = args.annotate_view == "debug"
            director.keep_stages = director.keep_stages or debug
            director.add_annotation_sink(PictureSink(writer, kind, debug=debug))
        bar = args.progress if reasons is None or not reasons.to_stderr else bool(args.progress)  # no bar amid them
        director.run_all(source, args.max_frames, stop=stopper.event, progress=BarProgress(bar))
        if director.stats.stopped_by == "stop":
            log.warning("stopped by %s after %d frames", stopper.reason, director.stats.frames)
    except KeyboardInterrupt:
        log.warning("interrupted after %d frames", director.stats.frames)
    except BrokenPipeError:
        raise
    except SourceError as exc:
        report(PROG, exc)
        status = 2 if director.stats.frames == 0 else 1  # nothing read at all: the source itself is bad
        keep_typed = status != 2
    except AnnotationError as exc:  # the pictures cannot be written: the other outputs keep what they got
        report(PROG, exc)
        status = 2
    except InputError as exc:  # an input refused mid-run (a frame over a limit): what was written is kept
        report(PROG, exc)
        status = 2
        keep_typed = director.stats.frames > 0
    except OutputError as exc:  # an output that cannot be written; a typed one is then left out entirely
        report(PROG, exc)
        status = 2
        keep_typed = typed is not None and _other_output(exc.path, args)
    except explain.ExplainWriteError as exc:
        report(PROG, exc)
        status = 2
    except OSError as exc:  # the output went away: a full disk, a closed device
        report(PROG, f"writing {args.output or 'the output'}: {exc.strerror or exc}")
        status = 2
    except BaseException:  # a user mistake found late or an unexpected error: no half-written typed output
        if typed is not None:
            typed.abort()
        raise
    finally:
        status = _close_output(writer, args.annotate, status)
        status = _close_output(recorder, args.rerun, status)
        status = _close_output(output, args.output, status)
        status = _close_reasons(reasons, status)
        source.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if typed is not None:
        status = _finish_typed(typed, keep=keep_typed, status=status)
    if status:
        return status
    stats = director.stats
    print(f"{PROG}: {stats.frames} frames, {stats.objects} objects, {stats.seconds:.2f} s, {stats.rate:.1f} frames/s",
          file=sys.stderr)
    if writer is not None:
        print(f"{PROG}: {writer.count} annotated frames written to {args.annotate}", file=sys.stderr)
    if typed is not None:
        print(f"{PROG}: {typed.count} messages on {typed.topic} written to {args.output}", file=sys.stderr)
    return 0


def _close_output(output: Any, path: str | None, status: int) -> int:
    """Close one output; a failure there (the last buffered bytes, a video's index) is exit code 2, reported
    unless the run already failed and said so."""
    if output is None:
        return status
    failure: object
    try:
        output.close()
    except (OutputError, AnnotationError) as exc:  # these name their file
        failure = exc
    except OSError as exc:
        failure = f"writing {path}: {exc.strerror or exc}"
    else:
        return status
    if not status:
        report(PROG, failure)
    return USER_ERROR


def _close_reasons(reasons: explain.Explainer | None, status: int) -> int:
    """Close the side file of reasons; a failure that was not reported yet is reported now."""
    if reasons is None:
        return status
    try:
        reasons.close()
    except explain.ExplainWriteError as exc:
        if not status:  # else the run already failed, and said so
            report(PROG, exc)
            return USER_ERROR
    return status


def _other_output(path: str, args: argparse.Namespace) -> bool:
    """Whether a failed write at ``path`` was one of the side outputs (pictures, recording), not --output."""
    failed = Path(path).resolve()
    sides = [Path(side).resolve() for side in (args.annotate, args.rerun) if side]
    return any(failed == side or failed.is_relative_to(side) for side in sides)


def _finish_typed(typed: Any, keep: bool, status: int) -> int:
    """Complete a typed output with everything written so far (also after a stop or a source that broke
    mid-stream), or drop it when the run wrote nothing usable; a failure to complete it is exit code 2."""
    if not keep:
        typed.abort()
        return status
    try:
        typed.close()
    except OutputError as exc:
        if not status:  # else the run already failed, and said so in its one line
            report(PROG, exc)
        return USER_ERROR
    return status


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except KeyboardInterrupt:  # before the run loop took Ctrl-C over (building the system, opening the source)
        sys.stderr.write(f"{PROG}: interrupted while starting\n")
        return INTERRUPTED


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(explain.bare_option_to_stderr(sys.argv[1:] if argv is None else argv))
    if not args.list_topics and (args.params is None or args.source is None):
        parser.error("PARAMS_FILE and --source are required (except with --list-topics)")
    configure_logging(PROG, args.verbose)
    try:
        check_limit_settings()
        return run(args, sys.stdout)
    except UserError as exc:
        report(PROG, exc)
        return USER_ERROR
    except PipelineError as exc:
        report(PROG, f"{args.params}: {exc}")
        return USER_ERROR
    except (InputError, OutputError) as exc:  # before the run loop: a reader's, a limit's or a writer's
        report(PROG, exc)
        return USER_ERROR
    except BrokenPipeError:  # the reader went away (e.g. `| head`): not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the interpreter's final flush stays quiet
        return 0


if __name__ == "__main__":
    sys.exit(main())
