"""objrec-detect: run any parameter file headless and stream the detected objects as JSON Lines, or write
them as typed ROS messages into an MCAP file, a ROS 1 bag or a ROS 2 bag folder (``--output``).

Exit codes: 0 done (also after Ctrl-C or SIGTERM, with everything written so far flushed and a typed
output completed); 1 a source that breaks mid-stream; 2 a user mistake (bad parameter file, option out of
its range, a source that cannot be opened or yields not even one frame, an input refused anywhere in the run
such as a frame over a declared limit, a detector that cannot detect, such as a feature detector without a
target), an output path refused before anything is written (the source or the parameter file, also through a
link; a read-only file, also as root; a FIFO: :mod:`strictio.output_paths`) and any output that cannot be
written (a full disk, a closed device; a typed output that cannot be written is left out entirely, what the
other outputs got so far is kept); 130 interrupted while starting.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import IO, Any

from objrec_core import (
    DetectionDirector,
    FrameSource,
    Kind,
    PipelineError,
    SourceError,
    UnknownModuleError,
    get_kind,
    open_source,
)
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, check_limit_settings
from strictio.shown import printable, valid_text
from strictio.signals import StopSignals

from . import explain, live_outputs, outputs
from .annotation_writer import PICTURE_NAMES, VIDEO_CODECS, AnnotationError
from .cli import (
    MAX_FRAMES,
    MESSAGE_LIMIT,
    USER_ERROR,
    UserError,
    configure_logging,
    detecting_system,
    report,
    run_command,
)
from .detection_outputs import OUTPUT_OPTION, DetectionLines, TypedDetections
from .foxglove_view import FoxgloveView, add_foxglove_argument
from .launch import ending_at_once
from .output_contract import Ending, Output, RunEnd, close_outputs
from .run_files import detection_inputs, source_outputs
from .side_outputs import Pictures, Reasons, RerunRecording

log = logging.getLogger("objrec.detect")
PROG = "objrec-detect"


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLineParser(
        prog=PROG,
        description="Detect objects with a parameter file made by objrec-define; one JSON line per frame, or "
        "typed ROS messages in an MCAP file or a bag.",
        epilog="Sources: a path (image, video, folder, cloud file, .bag, .mcap, ROS 2 bag folder) or "
        "scheme:key=value,... such as demo, demo:seed=3,frames=100, camera:0, rgbd:COLOR,DEPTH, "
        "bag:PATH,topic=NAME, or a live topic: ros1:/TOPIC[,master=URI,timeout=S], ros2:/TOPIC[,domain=N]. "
        "The parameter file's kind decides which are read.",
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
                        help="print the topics, types and message counts of a bag or MCAP file, or the topics "
                        "live now on ros1: (ros1:,master=URI) or ros2: (ros2:,domain=N), and exit")
    parser.add_argument(live_outputs.PUBLISH_OPTION, action="append", default=[], metavar="TARGET",
                        help="also publish the detections live as typed ROS messages: ros1:/TOPIC[,master=URI] "
                        "or ros2:/TOPIC[,domain=N] (repeatable)")
    parser.add_argument(live_outputs.ANNOTATED_OPTION, action="append", default=[], metavar="TARGET",
                        help="also publish each frame with its detections drawn as a sensor_msgs/Image "
                        "(bgr8), on ros1:/TOPIC or ros2:/TOPIC (repeatable)")
    parser.add_argument("--max-frames", "-n", type=MAX_FRAMES, metavar="N",
                        help=f"stop after N frames ({MAX_FRAMES.describe()})")
    parser.add_argument("--frame-id", default="camera",
                        help="frame_id written in headers when the source gives none (default: camera)")
    parser.add_argument(
        "--rerun", metavar="FILE.rrd|spawn",
        help="also log every frame, stage and detection to a Rerun recording (needs objrec[viz])",
    )
    add_foxglove_argument(parser)
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


def _open(args: argparse.Namespace) -> tuple[DetectionDirector, FrameSource, Kind]:
    system = detecting_system(args.params)
    director = DetectionDirector(system, frame_id=args.frame_id)
    not_ready = director.not_ready()
    if not_ready:
        raise UserError(f"{args.params}: " + "; ".join(not_ready))
    try:
        kind = get_kind(system.kind)
        source = open_source(args.source, kind.name)
    except (SourceError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None
    return director, source, kind


def _check_output_options(args: argparse.Namespace) -> None:
    """The output options that can be judged before anything is opened."""
    if valid_text(args.frame_id) != args.frame_id:  # bytes that are not UTF-8: no ROS message can carry them
        raise UserError(f"--frame-id {printable(args.frame_id)}: not UTF-8 text, which a ROS frame_id must be")
    for option, targets in ((live_outputs.PUBLISH_OPTION, args.publish),
                            (live_outputs.ANNOTATED_OPTION, args.publish_annotated)):
        for target in targets:
            live_outputs.live_target(target, option)  # a bad topic is refused before the source is waited for
    if args.output and outputs.is_typed_output(args.output):
        outputs.require_rosbags(f"--output {args.output}")
        if args.output_topic:
            args.output_topic = outputs.check_topic(args.output_topic)
        return
    for option, given in (("--output-topic", args.output_topic), ("--copy-input", args.copy_input)):
        if given:
            raise UserError(f"{option} needs a typed --output (FILE.mcap, FILE.bag or a ROS 2 bag folder)")


def _list_topics(args: argparse.Namespace, stdout: IO[str]) -> int:
    outputs.require_rosbags("--list-topics")
    from objrec_ros.bags import list_topics
    from objrec_ros.live.listing import is_live_spec, list_live_topics

    try:
        if is_live_spec(args.list_topics):
            text = list_live_topics(args.list_topics)
        else:
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


def _check_output_paths(args: argparse.Namespace) -> None:
    """Every output path judged against the run's inputs before anything is opened or written
    (:mod:`strictio.output_paths`): none may replace the parameter file or the source, be read-only, a FIFO."""
    files = detection_inputs(args.params, args.source)
    if args.output:
        typed = outputs.is_typed_output(args.output)
        bag_folder = typed and Path(args.output).suffix.lower() not in (".mcap", ".bag")
        files.writes(OUTPUT_OPTION, args.output, folder=bag_folder, stream=not typed)
    if args.explain not in (None, explain.STDERR):
        files.writes(explain.OPTION, args.explain, stream=True)
    if args.rerun and args.rerun != "spawn":
        files.writes("--rerun", args.rerun)
    if args.annotate:
        video = Path(args.annotate).suffix.lower() in VIDEO_CODECS
        files.writes("--annotate", args.annotate, folder=not video, names=PICTURE_NAMES)
    for option, path in source_outputs(args.source):
        files.writes(option, path)


@dataclass(frozen=True)
class RunInputs:
    """What the outputs are opened from: the options, the director they attach to, the source, the kind."""

    args: argparse.Namespace
    director: DetectionDirector
    source: FrameSource
    kind: Kind
    stdout: IO[str]


def _reasons(run: RunInputs) -> Output | None:
    return Reasons(run.args.explain) if run.args.explain is not None else None


def _recording(run: RunInputs) -> Output | None:
    return RerunRecording(run.args.rerun, run.kind, run.director.system) if run.args.rerun else None


def _live_view(run: RunInputs) -> Output | None:
    return FoxgloveView(run.args.foxglove, run.kind, run.director.system) if run.args.foxglove else None


def _detections(run: RunInputs) -> Output:
    """Typed messages where ``--output`` names a bag or MCAP file, else JSON Lines (stdout without it)."""
    args = run.args
    if not (args.output and outputs.is_typed_output(args.output)):
        return DetectionLines(args.output, run.stdout, skip_empty=args.skip_empty)
    system = run.director.system
    topic = args.output_topic or outputs.default_topic(system.object_name)
    copy = outputs.input_copy(run.source) if args.copy_input else None
    return TypedDetections(args.output, system.object_array_type, topic, copy, skip_empty=args.skip_empty)


def _pictures(run: RunInputs) -> Output | None:
    if not run.args.annotate:
        return None
    return Pictures(run.args.annotate, run.kind, debug=run.args.annotate_view == "debug")


def _published(run: RunInputs) -> Iterator[Output]:
    """One live publisher per ``--publish`` target, each on its own topic. Made one at a time, so the ones
    made before a target that fails are attached, and closed with the others."""
    array_type = run.director.system.object_array_type
    for target in run.args.publish:
        yield live_outputs.LiveDetections(target, array_type, skip_empty=run.args.skip_empty)


def _published_pictures(run: RunInputs) -> Iterator[Output]:
    for target in run.args.publish_annotated:
        yield live_outputs.LiveAnnotated(target, run.kind)


#: objrec-detect's outputs by the option that asks for each, in the order they are opened (and closed the
#: other way round); an entry gives None (or no outputs) where its option is not given, several (an iterable,
#: each attached as soon as it is made) where the option is repeated.
OUTPUTS: dict[str, Callable[[RunInputs], Output | Iterable[Output] | None]] = {
    explain.OPTION: _reasons,
    "--rerun": _recording,
    "--foxglove": _live_view,
    OUTPUT_OPTION: _detections,
    "--annotate": _pictures,
    live_outputs.PUBLISH_OPTION: _published,
    live_outputs.ANNOTATED_OPTION: _published_pictures,
}
#: What ends a run early with one line (anything else is a user mistake found late, or a bug).
_RUN_FAILURES = (SourceError, InputError, OutputError, AnnotationError, explain.ExplainWriteError, OSError)


def start(args: argparse.Namespace) -> tuple[DetectionDirector, FrameSource, Kind]:
    """Everything a run needs before its first frame, judged before anything is written: the options, the
    output paths, the system (a detector that can detect) and the source, open."""
    _check_output_options(args)
    _check_explain(args)
    _check_output_paths(args)
    return _open(args)


def run(args: argparse.Namespace, started: tuple[DetectionDirector, FrameSource, Kind], stdout: IO[str]) -> int:
    """The run loop over a started source, every output opened, flushed and summed up."""
    director, source, kind = started
    inputs = RunInputs(args, director, source, kind, stdout)
    opened: list[Output] = []
    end = RunEnd(Ending.FAILED, keep_partial=False)  # until the run says otherwise: a late mistake or a bug
    # Ctrl-C and SIGTERM end the loop between frames, everything flushed; a second Ctrl-C breaks a stuck source.
    with StopSignals(escalate=(signal.SIGINT,)) as stop:
        try:
            for open_output in OUTPUTS.values():
                made = open_output(inputs)
                for output in [made] if isinstance(made, Output) else made or ():
                    output.attach(director)
                    opened.append(output)
            bar = bool(args.progress) if any(o.uses_stderr for o in opened) else args.progress  # no bar amid reasons
            director.run_all(source, args.max_frames, stop=stop.event, progress=BarProgress(bar))
            end = RunEnd(Ending.COMPLETED)
            if director.stats.stopped_by == "stop":
                log.warning("stopped by %s after %d frames", stop.reason, director.stats.frames)
                end = RunEnd(Ending.INTERRUPTED)
        except KeyboardInterrupt:
            log.warning("interrupted after %d frames", director.stats.frames)
            end = RunEnd(Ending.INTERRUPTED)
        except BrokenPipeError:
            raise
        except _RUN_FAILURES as exc:
            end = _failed(exc, director.stats.frames, opened, args)
        finally:
            status = close_outputs(opened, end, partial(report, PROG))
            source_summary = source.run_summary()  # what a live source received and dropped
            source.close()
    if status:
        return status
    stats = director.stats
    print(f"{PROG}: {stats.frames} frames, {stats.objects} objects, {stats.seconds:.2f} s, {stats.rate:.1f} frames/s",
          file=sys.stderr)
    if source_summary:
        print(f"{PROG}: {printable(source_summary, limit=MESSAGE_LIMIT)}", file=sys.stderr)
    for output in reversed(opened):
        line = output.summary()
        if line:
            print(f"{PROG}: {printable(line, limit=MESSAGE_LIMIT)}", file=sys.stderr)
    return 0


def _failed(exc: Exception, frames: int, opened: Sequence[Output], args: argparse.Namespace) -> RunEnd:
    """Report a run that broke off in one line; how it ended, and whether the outputs keep what they got."""
    report_as: object = exc
    keep = True
    status = USER_ERROR
    if isinstance(exc, SourceError):  # nothing read at all: the source itself is bad, else it broke mid-stream
        status = USER_ERROR if frames == 0 else 1
        keep = frames > 0
    elif isinstance(exc, InputError):  # an input refused mid-run (a frame over a limit): what was written is kept
        keep = frames > 0
    elif isinstance(exc, OutputError):  # a typed output that cannot be written is left out; a side's failure not
        keep = any(o.holds(exc.path) for o in opened if o.option != OUTPUT_OPTION)
    elif isinstance(exc, OSError):  # the output went away: a full disk, a closed device
        report_as = f"writing {args.output or 'the output'}: {exc.strerror or exc}"
    report(PROG, report_as)
    return RunEnd(Ending.FAILED, status, keep_partial=keep)


def main(argv: list[str] | None = None) -> int:
    # Ctrl-C as KeyboardInterrupt is left only between the launcher's start-up handling and this command's
    # (``_main``): before the run loop took it over; a broken pipe (`| head`) is not an error.
    return run_command(PROG, lambda: _main(argv), mistakes=(UserError, InputError, OutputError),
                       interrupted="interrupted while starting")


def _main(argv: list[str] | None) -> int:
    # Until the run loop takes the signals over nothing is written, so a signal ends the command at once, one
    # line, 130. An interrupt raised as an exception could land anywhere in the start-up (in a plug-in's class
    # creation, which Python 3.11 wraps into a RuntimeError; in a generator being closed, where it is only
    # printed and then lost) and is not used here.
    with ending_at_once(PROG):
        parser = build_parser()
        args = parser.parse_args(explain.bare_option_to_stderr(sys.argv[1:] if argv is None else argv))
        if not args.list_topics and (args.params is None or args.source is None):
            parser.error("PARAMS_FILE and --source are required (except with --list-topics)")
        configure_logging(PROG, args.verbose)
        check_limit_settings()
        if args.list_topics:
            return _list_topics(args, sys.stdout)
        with _mistakes_of(args.params):
            started = start(args)
    with _mistakes_of(args.params):
        return run(args, started, sys.stdout)


@contextmanager
def _mistakes_of(params: str) -> Iterator[None]:
    """The system's mistakes (while it is built or while it runs) as the user's, naming its parameter file."""
    try:
        yield
    except PipelineError as exc:
        raise UserError(f"{params}: {exc}") from None


if __name__ == "__main__":
    sys.exit(main())
