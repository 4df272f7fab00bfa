"""What objrec-eval reads and checks before it scores: the label file (and the kind whose it is), the options a
kind's scorer takes, a source's own truth, and that no output folder is an input. Shared by the one-source
forms (:mod:`.evaluate`) and the batch (:mod:`.eval_batch`).
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Iterator
from itertools import islice
from pathlib import Path
from typing import Any

from objrec_core import (
    FrameSource,
    Kind,
    SourceError,
    SourceSpec,
    UnknownModuleError,
    get_kind,
    kind_names,
    open_source,
    source_schemes,
)
from objrec_core.evaluation import Evaluation, FrameTruth, Labelled, TruthSet
from objrec_core.kinds import NoGroundTruth
from strictio import InputError

from .cli import UserError


def scorer_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options given for the kind's scorer (``Kind.scorer(**options)``): only those given, so each kind
    keeps its own defaults."""
    return {"iou": args.iou} if args.iou is not None else {}


def read_truth(kind: Kind, path: str) -> TruthSet:
    """The label file, read by the kind; every failure one line naming the file."""
    if not Path(path).exists():
        raise UserError(f"{path}: the truth file does not exist")
    try:
        truth = kind.read_truth(path)
    except NoGroundTruth as exc:
        raise UserError(f"{path}: {exc}") from None
    if truth.kind != kind.name:
        raise UserError(f"{path}: kind: {truth.kind}, but the detections are of the {kind.name} kind")
    return truth


def truth_kind(path: str) -> Kind:
    """The kind whose label file ``path`` is, for saved JSON Lines without ``--kind``: the kind whose label format
    has the file's suffix (its complaint as it is, when it refuses the file), else the first kind that reads it."""
    suffix = Path(path).suffix.lower()
    kinds = [get_kind(name) for name in kind_names()]
    by_suffix = [k for k in kinds if suffix and f"({suffix})" in k.truth_format.lower()]
    if len(by_suffix) == 1:
        try:
            by_suffix[0].read_truth(path)
        except (InputError, ValueError) as exc:
            raise UserError(str(exc)) from None
        return by_suffix[0]
    first: Exception | None = None
    for kind in kinds:
        try:
            kind.read_truth(path)
        except NoGroundTruth:
            continue
        except (InputError, ValueError) as exc:
            first = first or exc
            continue
        return kind
    if first is not None:
        raise UserError(f"{first} (or give --kind)")
    raise UserError("no data kind reads label files")


def plain_paths(spec: str | None) -> list[Path]:
    """The file or folder a source spec names, if any (for the output-is-an-input check)."""
    if not spec:
        return []
    try:
        parsed = SourceSpec.parse(spec, source_schemes())
    except SourceError:
        return []
    if parsed.path is not None:
        return [parsed.path]
    return [Path(v) for v in (*parsed.positional, *parsed.options.values()) if "/" in v and Path(v).exists()]


#: The inputs that may be folders (an image folder, a ROS 2 bag folder, the label files of a batch): an output
#: folder inside one of them is refused too. A file given as a folder is the reader's to refuse.
FOLDER_INPUTS = ("the source", "the recording", "the detections", "the truth folder")


def refuse_output_inputs(out: str, inputs: Iterable[tuple[str, str | Path | None]]) -> None:
    """An output folder that is an input, holds one, or lies inside an input folder is refused: the reports
    and pictures would replace or be mixed with what was read."""
    folder = Path(out).expanduser().resolve()
    for what, path in inputs:
        if path is None:
            continue
        given = Path(path).expanduser().resolve()
        if given == folder or folder in given.parents:
            raise UserError(f"--out {out}: {what} {path} is in it; write the report to another folder")
        if given.is_dir() and what in FOLDER_INPUTS and given in folder.parents:
            raise UserError(f"--out {out}: inside {what} {path}; write the report to another folder")


def own_truth(kind: Kind, source: Iterable[Any], name: str) -> Iterator[Labelled]:
    """Each frame of a source that knows its truth, with that truth (``Kind.frame_truth``)."""
    for frame in source:
        label = kind.frame_truth(frame)
        if label is None:
            raise UserError(f"{name}: its frames carry no truth of their own: give --truth")
        yield frame, label


def own_truth_set(kind: Kind, spec: str, frames: int) -> TruthSet:
    """The truth a source knows of its own first ``frames`` frames, keyed by index (to score saved detections
    of it: the n-th array is frame n)."""
    with open_source_named(spec, kind) as source:
        labels = [label for _, label in own_truth(kind, islice(source, frames), spec)]
    return TruthSet(kind.name, [FrameTruth(i, f.stamp_ns, f.objects) for i, f in enumerate(labels)], "index")


def open_source_named(spec: str, kind: Kind) -> FrameSource:
    try:
        return open_source(spec, kind.name)
    except (SourceError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None


def empty_evaluation(kind: Kind, args: argparse.Namespace) -> Evaluation:
    try:
        return kind.scorer(**scorer_options(args)).result()
    except NoGroundTruth as exc:
        raise UserError(str(exc)) from None
    except TypeError:  # an option this kind's scorer does not take
        options = ", ".join(f"--{name}" for name in scorer_options(args))
        raise UserError(f"{options}: not an option of the {kind.name} kind's scoring") from None
