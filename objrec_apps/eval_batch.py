"""objrec-eval over many recordings: ``objrec-eval PARAMS_FILE RECORDING... [--truth-dir DIR]``.

The system runs on objrec-batch's Dask path unchanged (:func:`objrec_apps.batch.make_plan` checks the parameter
file and names one output per recording, :func:`objrec_apps.batch.run_batch` runs
:func:`objrec_apps.batch_worker.run_source` on each, in parallel, into ``OUT/detections/<stem>.jsonl``); the
saved detections are then scored here, each against its own label file (``DIR/<stem>.<ext>``, the stem the
output takes) or, without ``--truth-dir``, against the source's own truth (a demo). Scoring saved detections is
quick next to running a system, so it stays in this process, and the figures are the same as
``objrec-eval OUT/detections/<stem>.jsonl --truth DIR/<stem>.<ext>`` would give one by one.

Output: a table with one row per recording (its "all" figures) and the combined table on stdout; in ``--out``
the combined ``report.json`` (with each recording's figures under ``recordings``), ``report.md``, the
pictures, and ``recordings/<output stem>/`` with each recording's own reports. Ctrl-C or SIGTERM stops the
running recordings after their frame (as objrec-batch does) and the report holds what they did.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

from objrec_core import DetectedObjectArray, Kind, SourceError, build_system, get_kind, open_source, source_schemes
from objrec_core.evaluation import Evaluation, FrameTruth, TruthSet, saved_pairs, score_saved
from strictio.signals import handling, raise_interrupt

from . import eval_saved
from .batch import EXIT_FAILED, EXIT_INTERRUPTED, BatchOutcome, make_plan, run_batch
from .batch_worker import FAILED, STOPPED, output_stem
from .cli import UserError
from .eval_inputs import empty_evaluation, own_truth_set, read_truth, scorer_options
from .eval_report import bars_asked, check_bars, format_table, missed_bars, write_report
from .evaluate import bars_exit

log = logging.getLogger("objrec.eval")
PROG = "objrec-eval"
DETECTIONS = "detections"
RECORDINGS = "recordings"
#: The status of a recording whose detections could not be scored (a label file that does not fit them).
NOT_SCORED = "not scored"


def label_file(truth_dir: Path, stem: str) -> Path:
    """The label file of a recording: the one file in ``truth_dir`` named ``stem`` with any suffix."""
    found = sorted(p for p in truth_dir.glob(f"{_glob_safe(stem)}.*") if p.is_file() and p.stem == stem)
    if not found:
        raise UserError(f"--truth-dir {truth_dir}: no label file {stem}.* for the recording {stem}")
    if len(found) > 1:
        raise UserError(f"--truth-dir {truth_dir}: several label files for {stem}: "
                        f"{', '.join(p.name for p in found)}")
    return found[0]


def _glob_safe(stem: str) -> str:
    return "".join(f"[{c}]" if c in "*?[]" else c for c in stem)


def _check_own_truth(kind: Kind, spec: str) -> None:
    """Before the batch: a source scored by its own truth must have one (its first frame is asked)."""
    with open_source(spec, kind.name) as source:
        frame = next(iter(source), None)
        if frame is not None and kind.frame_truth(frame) is None:
            raise UserError(f"{spec}: its frames carry no truth of their own: give --truth-dir with its label file")


def run_batch_evaluation(args: argparse.Namespace, params: str, specs: Sequence[str], stdout: IO[str]) -> int:
    """Run the batch, score every recording and all together, report; the exit code."""
    if args.truth:
        raise UserError("--truth is for one source; a batch reads one label file per recording from --truth-dir")
    if args.topic or args.kind:
        raise UserError("--topic and --kind are for saved detections, not a batch")
    out = Path(args.out)
    plan = make_plan(params, specs, str(out / DETECTIONS), "jsonl", args.max_frames)  # checks the parameter file
    kind = get_kind(build_system(params).kind)
    bars = bars_asked(args)
    check_bars(bars, empty_evaluation(kind, args), kind.name)
    schemes = source_schemes()
    stems = [output_stem(spec, schemes) for spec in specs]
    truth_dir = Path(args.truth_dir) if args.truth_dir else None
    if truth_dir is not None and not truth_dir.is_dir():
        raise UserError(f"--truth-dir {truth_dir}: not a folder")
    truths: list[TruthSet | None] = []
    for spec, stem in zip(specs, stems, strict=True):
        if truth_dir is not None:
            truths.append(read_truth(kind, str(label_file(truth_dir, stem))))
        else:
            _check_own_truth(kind, spec)
            truths.append(None)
    try:
        with handling(raise_interrupt, (signal.SIGTERM,)):  # SIGTERM as Ctrl-C, as objrec-batch takes it
            outcome = run_batch(plan, args.workers, args.scheduler, args.progress)
    except KeyboardInterrupt:  # while the cluster was starting: nothing ran
        sys.stderr.write(f"{PROG}: interrupted while the cluster started\n")
        return EXIT_INTERRUPTED
    rows, evaluations, pairs = _score_each(kind, plan.specs, plan.outputs, plan.out_dir, truths, outcome, args)
    combined = _combined(kind, pairs, scorer_options(args))
    for (spec, evaluation), name in zip(evaluations, plan.outputs, strict=True):
        if evaluation is not None:  # a folder per output name: unique where two recordings share a stem
            write_report(out / RECORDINGS / Path(name).stem, evaluation, {"params": params, "source": spec},
                         pictures=False)
    missed = missed_bars(combined, bars)
    per_recording = {spec: e.to_dict() for spec, e in evaluations if e is not None}
    write_report(out, combined, {"params": params, "sources": list(specs), "truth_dir": args.truth_dir,
                                 "interrupted": outcome.interrupted},
                 {"recordings": per_recording, "batch": rows, "bars": bars, "missed": missed},
                 pictures=not args.no_pictures)
    stdout.write(format_table(rows, first="recording"))
    stdout.write("\n")
    stdout.write(format_table(combined.summary_rows(), first="name"))
    stdout.flush()
    failed = [r for r in rows if r["status"].startswith((FAILED, NOT_SCORED))]
    sys.stderr.write(f"{PROG}: {len(specs)} recordings, {len(failed)} not scored, {combined.frames} frames "
                     f"scored, score {combined.score:.3f}; report in {out}\n")
    if outcome.interrupted:
        return 0
    code = bars_exit(missed)
    return EXIT_FAILED if failed else code


def _score_each(kind: Kind, specs: Sequence[str], outputs: Sequence[str], folder: Path,
                truths: Sequence[TruthSet | None], outcome: BatchOutcome, args: argparse.Namespace
                ) -> tuple[list[dict[str, Any]], list[tuple[str, Evaluation | None]],
                           list[tuple[FrameTruth, DetectedObjectArray]]]:
    """Each recording's row and evaluation, and every (truth, detections) pair for the combined figures."""
    rows: list[dict[str, Any]] = []
    evaluations: list[tuple[str, Evaluation | None]] = []
    pairs: list[tuple[FrameTruth, DetectedObjectArray]] = []
    for spec, name, truth, result in zip(specs, outputs, truths, outcome.results, strict=True):
        row: dict[str, Any] = {"recording": spec, "frames": result.frames, "status": result.status}
        evaluation = None
        if result.ok or result.status == STOPPED:
            try:
                arrays = list(eval_saved.read_json_lines(str(folder / name), kind))
                if truth is None:
                    truth = own_truth_set(kind, spec, len(arrays))
                evaluation = score_saved(kind, arrays, truth, **scorer_options(args))
                pairs.extend(saved_pairs(arrays, truth))
                all_row = next((r for r in evaluation.summary_rows() if r.get("name") == "all"), {})
                row.update({k: v for k, v in all_row.items() if k != "name"})
            except (UserError, SourceError, ValueError, OSError) as exc:  # a row, not the end of the batch
                row["status"] = f"{NOT_SCORED}: {' '.join(str(exc).split())}"
        rows.append(row)
        evaluations.append((spec, evaluation))
    return rows, evaluations, pairs


def _combined(kind: Kind, pairs: Sequence[tuple[FrameTruth, DetectedObjectArray]], options: dict[str, Any]
              ) -> Evaluation:
    """Every recording's labelled frames scored as one set."""
    scorer = kind.scorer(**options)
    for label, array in pairs:
        scorer.add(label, array, None)
    return scorer.result()
