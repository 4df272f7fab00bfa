"""objrec-tune: search a parameter file's declared parameters for the best score on labelled frames.

``objrec-tune PARAMS_FILE --source S [--truth T] --trials N --out tuned.yaml [--seed 0] [--held-out 0.3]
[--fix MODULE.PARAM ...] [--search MODULE.PARAM ...] [--timeout S]``

The labelled frames are read once; a share of them (``--held-out``) is never seen by the search and is scored
once with the best parameters: that is the score reported, and written into the tuned file's description with
what it was tuned on. Without ``--truth`` the source's own truth labels every frame (the demos know what they
drew). The search is :func:`objrec_core.tuning.tune` (Optuna's TPE sampler, seeded: one seed gives one file,
unless ``--timeout`` cuts it short). Progress goes to stderr; stdout gets the scores and the table of which
parameters mattered.

Exit codes: 0 tuned; 2 a user mistake (a bad file, option, source or name, an output that is an input, an
output that cannot be written, no ``tune`` extra); 130 interrupted (Ctrl-C or SIGTERM during the search: the
best parameters so far are still scored and written; while reading the frames or a second time: nothing is
written).
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import IO, Any

from objrec_core import (
    Kind,
    ParameterFileError,
    ParameterStorage,
    PipelineError,
    RecognitionSystem,
    SourceError,
    UnknownModuleError,
    get_kind,
    open_source,
)
from objrec_core.evaluation import Labelled, load_labelled
from objrec_core.kinds import NoGroundTruth
from objrec_core.tuning import (
    NEEDS_EXTRA,
    SearchSpaceError,
    TuningError,
    TuningProgress,
    TuningResult,
    TuningUnavailable,
    search_space,
    tune,
)
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, Number
from strictio.signals import StopSignals

from .cli import INTERRUPTED, MAX_FRAMES, UserError, detecting_system, parse_and_run, run_command
from .evaluate import own_truth, plain_paths, read_truth
from .launch import ending_at_once

log = logging.getLogger("objrec.tune")
PROG = "objrec-tune"
TRIALS = Number(1, 1_000_000, whole=True)
SEED = Number(0, 2**32 - 1, whole=True)
SHARE = Number(0, 1)
SECONDS = Number(0, None, above=True)
#: A progress line at least every this many trials (and whenever the best improves).
PROGRESS_EVERY = 25


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLineParser(
        prog=PROG,
        description="Tune a parameter file on labelled frames: Optuna's TPE sampler searches the parameters' "
        "declared ranges; a held-out share of the frames scores the result.",
        epilog="names: MODULE_ID.PARAMETER as the parameter file has them (colour.h_min), or a module id for all "
        "of its parameters.\nexit codes: 0 tuned; 2 a user mistake; 130 interrupted (during the search the best "
        "so far is still written).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("params", metavar="PARAMS_FILE", help="the parameter file (YAML) to start from")
    parser.add_argument("--source", "-s", required=True, help="the labelled frames' source (demo:frames=N, a "
                        "folder, a video, a bag...)")
    parser.add_argument("--truth", "-t", metavar="FILE", help="the label file (2D: COCO JSON; 3D: the shapes "
                        "file); omit it where the source knows its own truth (the demos)")
    parser.add_argument("--trials", "-n", type=TRIALS, required=True, metavar="N",
                        help=f"parameter sets to try ({TRIALS.describe()})")
    parser.add_argument("--out", "-o", required=True, metavar="FILE", help="the tuned parameter file (written "
                        "atomically; may not be an input)")
    parser.add_argument("--seed", type=SEED, default=0, help="seed of the sampler and the split (default 0)")
    parser.add_argument("--held-out", type=SHARE, default=0.3, metavar="SHARE",
                        help="share of the labelled frames never searched, whose score is reported (default 0.3; "
                        "0 holds none out)")
    parser.add_argument("--fix", nargs="+", action="extend", default=[], metavar="NAME",
                        help="keep these parameters at the file's values")
    parser.add_argument("--search", nargs="+", action="extend", default=None, metavar="NAME",
                        help="search only these parameters (the others keep the file's values)")
    parser.add_argument("--timeout", type=SECONDS, metavar="S", help="stop searching after S seconds (the result "
                        "then depends on the machine's speed)")
    parser.add_argument("--max-frames", type=MAX_FRAMES, metavar="N",
                        help="use at most N labelled frames (needed for an endless source with its own truth)")
    parser.add_argument("--iou", type=Number(0, 1, above=True), metavar="X",
                        help="2D: the IoU a detection needs to match a truth box (the kind's default: 0.5)")
    parser.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    return parser


def refuse_inputs(out: str, inputs: Iterable[tuple[str, str | Path | None]]) -> None:
    """The tuned file may not replace what was read (the parameter file itself, the labels, the source)."""
    target = Path(out).expanduser().resolve()
    if target.is_dir():
        raise UserError(f"--out {out}: is a folder; give the tuned parameter file's name")
    if not target.parent.is_dir():  # found now, not after the whole search
        raise UserError(f"--out {out}: the folder {Path(out).parent} does not exist")
    for what, path in inputs:
        if path is not None and Path(path).expanduser().resolve() == target:
            raise UserError(f"--out {out}: is {what}; write the tuned file elsewhere (an output never replaces "
                            "an input)")


def _require_optuna() -> None:
    try:
        import optuna  # noqa: F401 - only whether it is there
    except ImportError:
        raise UserError(NEEDS_EXTRA) from None


def load_frames(args: argparse.Namespace, kind: Any, stop: Any) -> list[Labelled]:
    """The labelled frames, read once: those ``--truth`` labels, or the source's own truth for each frame."""
    truth = read_truth(kind, args.truth) if args.truth else None
    try:
        source = open_source(args.source, kind.name)
    except (SourceError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None
    with source:
        if truth is None and source.length is None and args.max_frames is None:
            raise UserError(f"--source {args.source}: has no end: give --max-frames N (or frames=N in the spec)")
        try:
            if truth is not None:
                frames = load_labelled(source, truth, stop)
            else:
                frames = list(own_truth(kind, _stopping(source, stop), args.source))
        except SourceError as exc:
            raise UserError(str(exc)) from None
    if args.max_frames is not None:
        frames = frames[:args.max_frames]
    return frames


def _stopping(frames: Iterable[Any], stop: Any) -> Iterable[Any]:
    for frame in frames:
        if stop.is_set():
            return
        yield frame


class ProgressLines:
    """Progress on stderr: a line whenever the best score improves, and every ``PROGRESS_EVERY`` trials."""

    def __init__(self, stream: IO[str]) -> None:
        self.stream = stream
        self.best: float | None = None

    def __call__(self, update: TuningProgress) -> None:
        improved = update.best is not None and (self.best is None or update.best > self.best)
        if improved or update.trial % PROGRESS_EVERY == 0 or update.trial == update.trials:
            score = "broke a rule" if update.score is None else f"score {update.score:.3f}"
            best = "none yet" if update.best is None else f"{update.best:.3f}"
            self.stream.write(f"{PROG}: trial {update.trial}/{update.trials}: {score}, best {best}"
                              f"{' (new best)' if improved else ''}\n")
            self.stream.flush()
        if update.best is not None:
            self.best = update.best


def run(args: argparse.Namespace, stdout: IO[str]) -> int:
    # Nothing is open or written before the frames are read: a signal while the system is built ends at once.
    with ending_at_once(PROG):
        system, kind, options = _start(args)
    with StopSignals() as stop:
        frames = load_frames(args, kind, stop.event)
        if stop.event.is_set():
            sys.stderr.write(f"{PROG}: interrupted while reading the labelled frames: nothing written\n")
            return INTERRUPTED
        sys.stderr.write(f"{PROG}: {len(frames)} labelled frames; {args.trials} trials, seed {args.seed}, "
                         f"held-out share {args.held_out:g}\n")
        try:
            result = tune(system, kind, frames, args.trials, args.seed, args.held_out, args.fix, stop.event,
                          ProgressLines(sys.stderr), search=args.search, timeout=args.timeout,
                          scorer_options=options)
        except (TuningError, SearchSpaceError) as exc:
            if stop.event.is_set():
                sys.stderr.write(f"{PROG}: interrupted before any trial finished: nothing written\n")
                return INTERRUPTED
            raise UserError(str(exc)) from None
        except TuningUnavailable:
            raise UserError(NEEDS_EXTRA) from None
    write_tuned(args, result)
    stdout.write(summary(result))
    stdout.flush()
    if result.stopped:
        sys.stderr.write(f"{PROG}: interrupted after {result.trials} trials: the best so far is in {args.out}\n")
        return INTERRUPTED
    return 0


def _start(args: argparse.Namespace) -> tuple[RecognitionSystem, Kind, dict[str, Any]]:
    """Everything judged before a frame is read: the options, the outputs, the system and its search space;
    the system, its kind and the scorer's options."""
    _require_optuna()
    if args.held_out >= 1:
        raise UserError(f"--held-out {args.held_out}: must be below 1 (some frames must be searched)")
    refuse_inputs(args.out, [("the parameter file", args.params), ("the truth file", args.truth),
                             *(("the source", p) for p in plain_paths(args.source))])
    system = detecting_system(args.params)
    kind = get_kind(system.kind)
    try:
        kind.scorer()
    except NoGroundTruth as exc:
        raise UserError(f"{args.params}: {exc}") from None
    try:  # names and an empty space are refused before any frame is read
        space = search_space(system.modules, args.fix, args.search)
    except SearchSpaceError as exc:
        raise UserError(str(exc)) from None
    if not space.dimensions:
        raise UserError("nothing to search: every parameter is fixed, untuned or of a type the search skips")
    return system, kind, {"iou": args.iou} if args.iou is not None else {}


def write_tuned(args: argparse.Namespace, result: TuningResult) -> None:
    """The tuned system, its description saying what it was tuned on, saved atomically."""
    system = result.system
    said = result.description(args.source, args.truth)
    system.description = f"{system.description}\n{said}" if system.description else said
    try:
        ParameterStorage(system).save_parameters(args.out)
    except ParameterFileError as exc:
        raise UserError(str(exc)) from None


def summary(result: TuningResult) -> str:
    """What stdout gets: the scores, then the table of which parameters mattered."""
    lines = [f"{result.score_line()}; best of {result.trials} trials: trial {result.best_trial}"
             + (f" ({result.broken} broke a rule)" if result.broken else "")]
    return "\n".join(lines) + "\n" + result.table()


def main(argv: list[str] | None = None) -> int:
    return run_command(PROG, lambda: parse_and_run(PROG, build_parser(), argv, run),
                       mistakes=(UserError, PipelineError, InputError, OutputError, SourceError))


if __name__ == "__main__":
    sys.exit(main())
