"""objrec-eval: how good is a system? Score its detections against ground truth.

Three forms:

- ``objrec-eval PARAMS_FILE --source S [--truth T]`` runs the parameter file's system over the labelled frames of
  the source and scores them; without ``--truth`` the source's own truth labels every frame (the demos know
  what they drew).
- ``objrec-eval DETECTIONS --truth T`` (or ``--source S`` for the source's own truth) scores detections saved
  earlier: objrec-detect's JSON Lines, or its typed output (an MCAP file, a ROS 1 bag, a ROS 2 bag folder).
- ``objrec-eval PARAMS_FILE RECORDING... [--truth-dir DIR]`` runs the system over many recordings on the same
  Dask path as objrec-batch and scores each against its label file (same stem in DIR), and all together.

Output: the summary table on stdout, and in ``--out`` (default ``evaluation``) ``report.json``, ``report.md`` and
the kind's pictures. Exit codes: 0 scored (also after Ctrl-C or SIGTERM: the report holds the frames scored so
far); 1 below a bar given with ``--min-f1`` and the like (one line per bar missed), or a batch's recording
that failed (its row says why); 2 a user mistake (a bad
file, option or source, an output that is an input, an output that cannot be written); 130 interrupted while
starting or a second time.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path
from typing import IO, Any

from objrec_core import (
    FrameSource,
    Kind,
    PipelineError,
    SourceError,
    UnknownModuleError,
    get_kind,
    kind_names,
)
from objrec_core.evaluation import Evaluation, Labelled, TruthSet, labelled_frames, score, score_saved
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, Number
from strictio.signals import StopSignals

from . import eval_saved
from .cli import MAX_FRAMES, UserError, detecting_system, parse_and_run, run_command
from .detect import BarProgress
from .eval_inputs import (
    empty_evaluation,
    open_source_named,
    own_truth,
    own_truth_set,
    plain_paths,
    read_truth,
    refuse_output_inputs,
    scorer_options,
    truth_kind,
)
from .eval_inspection import (
    add_inspection_arguments,
    inspection_command,
    inspection_evaluation,
    refuse_stray_inspection_options,
)
from .eval_report import (
    BAR_OPTIONS,
    BELOW_BAR,
    bar_dest,
    bars_asked,
    check_bars,
    format_table,
    make_out_dir,
    missed_bars,
    write_report,
)
from .launch import ending_at_once

log = logging.getLogger("objrec.eval")
PROG = "objrec-eval"
#: The suffixes of a parameter file.
PARAMS_SUFFIXES = (".yaml", ".yml")
#: A bar's value: a share (precision, recall, F1, AP, IDF1), metres (centre, radius error) or degrees (axis error).
BAR = Number(0, None)
DEFAULT_OUT = "evaluation"
#: What a bar's X is counted in, where it is not a share in 0..1.
BAR_UNITS = {"centre_error_p90": " metres (3D)", "radius_error_p90": " metres (3D)", "axis_error_p90": " degrees (3D)",
             "idf1": " (3D tracking)"}


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLineParser(
        prog=PROG,
        description="Score a recognition system against ground truth: run a parameter file over the labelled "
        "frames of a source, or score detections saved by objrec-detect; or many recordings on Dask.",
        epilog="exit codes: 0 scored (also after Ctrl-C: the report holds the frames scored so far); 1 below a "
        "--min-*/--max-* bar; 2 a user mistake; 130 interrupted while starting.",
    )
    parser.add_argument("input", metavar="PARAMS_FILE|DETECTIONS", nargs="?",
                        help="a parameter file (YAML; with --source, or followed by recordings for a batch), or "
                        "saved detections: JSON Lines, an MCAP file, a ROS 1 bag or a ROS 2 bag folder")
    parser.add_argument("recordings", metavar="RECORDING", nargs="*",
                        help="batch: recordings (or any sources) to run the parameter file over on Dask")
    parser.add_argument("--source", "-s", help="the source the parameter file runs on, or whose own truth scores "
                        "saved detections (demo:frames=N, a folder, a video, a bag...)")
    parser.add_argument("--truth", "-t", metavar="FILE",
                        help="the label file (2D: COCO JSON; 3D: the shapes file); omit it where the source "
                        "knows its own truth (the demos)")
    parser.add_argument("--truth-dir", metavar="DIR",
                        help="batch: the label files, one per recording with the recording's stem")
    parser.add_argument("--kind", help="the data kind of saved JSON Lines (default: the one whose label file "
                        "the truth is)")
    parser.add_argument("--topic", help="the topic of the detections in a recording with several")
    add_inspection_arguments(parser)
    parser.add_argument("--out", "-o", metavar="DIR", default=DEFAULT_OUT,
                        help="folder for report.json, report.md and the pictures (default: evaluation); made if "
                        "missing; may hold no input")
    for option, name in BAR_OPTIONS.items():
        upper = option.startswith("--max-")
        parser.add_argument(option, type=BAR, metavar="X", dest=bar_dest(option),
                            help=f"exit 1 when {name} is {'above' if upper else 'below'} X{BAR_UNITS.get(name, '')}")
    parser.add_argument("--iou", type=Number(0, 1, above=True), metavar="X",
                        help="2D: the IoU a detection needs to match a truth box (the kind's default: 0.5)")
    parser.add_argument("--max-frames", "-n", type=MAX_FRAMES, metavar="N",
                        help=f"score at most N labelled frames ({MAX_FRAMES.describe()})")
    parser.add_argument("--workers", "-w", type=Number(1, 256, whole=True), metavar="N",
                        help="batch: worker processes of the local Dask cluster (default: the cores available)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="batch: an existing Dask scheduler")
    parser.add_argument("--no-pictures", action="store_true", help="write the reports only")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                        help="progress bar on stderr (default: on a terminal)")
    parser.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    return parser


# -- what is read --------------------------------------------------------------------------------------------
def is_params(path: str) -> bool:
    return Path(path).suffix.lower() in PARAMS_SUFFIXES


# -- running -----------------------------------------------------------------------------------------------
@dataclass
class Scored:
    """An evaluation and what it was made of, for the report."""

    evaluation: Evaluation
    command: dict[str, Any] = field(default_factory=dict)
    interrupted: bool = False


def _length(source: FrameSource, args: argparse.Namespace, truth: TruthSet | None) -> int | None:
    """How many frames will be scored, where known (the progress bar's total)."""
    counts = [n for n in (args.max_frames, len(truth) if truth is not None else source.length) if n is not None]
    return min(counts) if counts else None


def run_system(args: argparse.Namespace, params: str) -> Scored:
    """Run the parameter file's system over the labelled frames of ``--source``."""
    # Nothing is written before the frames are scored (the report's folder at most, empty): a signal while the
    # system is built or the source opened ends the command at once.
    with ending_at_once(PROG):
        system = detecting_system(params)
        kind = get_kind(system.kind)
        truth = read_truth(kind, args.truth) if args.truth else None
        bars = bars_asked(args)
        check_bars(bars, empty_evaluation(kind, args), kind.name)
        source = open_source_named(args.source, kind)
        if truth is None and source.length is None and args.max_frames is None:
            source.close()
            raise UserError(f"--source {args.source}: has no end: give --max-frames N (or frames=N in the spec)")
        try:
            make_out_dir(Path(args.out))  # before the run, not after it
        except UserError:
            source.close()
            raise
    progress = BarProgress(args.progress)
    frames_done = 0

    def advance(_frame: Any, _objects: Any) -> None:
        nonlocal frames_done
        frames_done += 1
        progress.advance()

    interrupted = False
    with StopSignals(escalate=(signal.SIGINT,)) as stop, source:
        if truth is not None:
            frames: Iterable[Labelled] = labelled_frames(source, truth, stop.event)
        else:
            frames = own_truth(kind, source, args.source)
        if args.max_frames is not None:
            frames = islice(frames, args.max_frames)
        progress.start(_length(source, args, truth))
        try:
            evaluation = score(system, kind, frames, stop=stop.event, on_frame=advance, **scorer_options(args))
        except SourceError as exc:
            raise UserError(str(exc)) from None
        finally:
            progress.close()
        if stop.event.is_set():
            interrupted = True
            log.warning("stopped by %s after %d frames: the report holds those", stop.reason, frames_done)
    command = {"params": params, "source": args.source, "truth": args.truth or "the source's own",
               "frames": frames_done, "interrupted": interrupted}
    return Scored(evaluation, command, interrupted)


def score_detections(args: argparse.Namespace, path: str) -> Scored:
    """Score detections saved earlier against ``--truth`` or the own truth of ``--source``."""
    if not args.truth and not args.source:
        raise UserError(f"{path}: give --truth (the label file), or --source for a source with its own truth")
    if eval_saved.is_recording(path):
        topic, kind = eval_saved.detection_topic(path, args.topic)
        if args.kind and args.kind != kind.name:
            raise UserError(f"--kind {args.kind}: {path} holds {kind.name} detections on {topic}")
        arrays = eval_saved.with_skipped_frames(list(eval_saved.read_recording(path, topic, kind)), path)
    else:
        if args.topic:
            raise UserError(f"--topic: {path} is JSON Lines, which have no topics")
        kind = _kind_named(args.kind) if args.kind else truth_kind(args.truth) if args.truth else None
        if kind is None:
            raise UserError(f"{path}: JSON Lines do not say their kind: give --kind ({', '.join(kind_names())})")
        arrays = eval_saved.with_skipped_frames(list(eval_saved.read_json_lines(path, kind)), path)
    bars = bars_asked(args)
    check_bars(bars, empty_evaluation(kind, args), kind.name)
    if args.max_frames is not None:
        arrays = arrays[:args.max_frames]
    if args.truth:
        truth = read_truth(kind, args.truth)
    else:
        truth = own_truth_set(kind, args.source, len(arrays))
    make_out_dir(Path(args.out))
    evaluation = score_saved(kind, arrays, truth, **scorer_options(args))
    command = {"detections": path, "truth": args.truth or f"the own truth of {args.source}",
               "frames": evaluation.frames, "interrupted": False}
    return Scored(evaluation, command)


def _kind_named(name: str) -> Kind:
    try:
        return get_kind(name)
    except (UnknownModuleError, KeyError, LookupError):
        raise UserError(f"--kind {name}: unknown (kinds: {', '.join(kind_names())})") from None


def finish(args: argparse.Namespace, scored: Scored, stdout: IO[str]) -> int:
    """Print the table, write the reports, judge the bars: the exit code."""
    evaluation = scored.evaluation
    bars = bars_asked(args)
    missed = missed_bars(evaluation, bars)
    written = write_report(Path(args.out), evaluation, scored.command, {"bars": bars, "missed": missed},
                           pictures=not args.no_pictures)  # first: a reader of stdout gone still leaves the report
    stdout.write(format_table(evaluation.summary_rows(), first="name"))
    stdout.flush()
    sys.stderr.write(f"{PROG}: {evaluation.frames} frames scored, score {evaluation.score:.3f}; report in "
                     f"{written[0].parent}{' (interrupted: the frames scored so far)' if scored.interrupted else ''}\n")
    if scored.interrupted:
        return 0
    return bars_exit(missed)


def bars_exit(missed: list[str]) -> int:
    """The exit code of a scoring that was not interrupted: one stderr line per bar missed, then 1 (BELOW_BAR)
    if any was, else 0. Shared by the one-source and the batch form."""
    for line in missed:
        sys.stderr.write(f"{PROG}: below the bar: {line}\n")
    return BELOW_BAR if missed else 0


def run(args: argparse.Namespace, stdout: IO[str]) -> int:
    refuse_stray_inspection_options(args)
    if args.inspection:
        if args.input or args.recordings or args.source or args.truth_dir:
            raise UserError("--inspection: scores an objrec-inspect report on its own: give no PARAMS_FILE, "
                            "DETECTIONS, --source or --truth-dir")
        refuse_output_inputs(args.out, [("the inspection report", args.inspection), ("the world file", args.truth)])
        confusion = inspection_evaluation(args)
        return finish(args, Scored(confusion, inspection_command(confusion)), stdout)
    if not args.input:
        raise UserError("give PARAMS_FILE --source S, DETECTIONS --truth T, or --inspection REPORT_JSON")
    first, rest = args.input, args.recordings
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise UserError(f"--out {args.out}: exists and is not a folder")
    inputs: list[tuple[str, str | Path | None]] = [("the truth file", args.truth), ("the truth folder", args.truth_dir)]
    if rest:
        if not is_params(first):
            raise UserError(f"{first}: a batch starts with a parameter file (.yaml), then the recordings")
        if args.source:
            raise UserError("--source: a batch takes its recordings as arguments after the parameter file")
        from .eval_batch import run_batch_evaluation

        refuse_output_inputs(args.out, [*inputs, ("the parameter file", first),
                                        *(("the recording", p) for spec in rest for p in plain_paths(spec))])
        return run_batch_evaluation(args, first, rest, stdout)
    if args.truth_dir:
        raise UserError("--truth-dir is for a batch: PARAMS_FILE RECORDING... (use --truth for one source)")
    if is_params(first):
        if not args.source:
            raise UserError(f"{first}: give --source (the frames to run the system on), or recordings after it")
        refuse_output_inputs(args.out, [*inputs, ("the parameter file", first),
                                        *(("the source", p) for p in plain_paths(args.source))])
        scored = run_system(args, first)
    else:
        refuse_output_inputs(args.out, [*inputs, ("the detections", first),
                                        *(("the source", p) for p in plain_paths(args.source))])
        scored = score_detections(args, first)
    return finish(args, scored, stdout)


def main(argv: list[str] | None = None) -> int:
    # A broken pipe (`| head`) is not an error: the report files have it all.
    return run_command(PROG, lambda: parse_and_run(PROG, build_parser(), argv, run),
                       mistakes=(UserError, PipelineError, InputError, OutputError, SourceError))


if __name__ == "__main__":
    sys.exit(main())
