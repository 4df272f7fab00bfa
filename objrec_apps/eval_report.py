"""What objrec-eval shows and writes: the summary table on stdout, ``report.json``, ``report.md`` and the kind's
pictures in the output folder, and the bars a user's CI sets (``--min-f1`` ...).

The figures are the kind's :class:`~objrec_core.evaluation.Evaluation` (its ``summary_rows``, ``to_dict``,
``markdown``, ``pictures``, ``below``): this module only lays them out and writes them, so the command, the
GUI's quality strip and objrec-tune cannot disagree on a number.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from objrec_core.evaluation import Evaluation
from strictio import OutputError, write_atomically

from .cli import UserError

#: The exit code below a bar (or above a ``--max-`` one).
BELOW_BAR = 1
REPORT_JSON = "report.json"
REPORT_MD = "report.md"
#: Each bar option and the figure it names in ``Evaluation.below`` (a ``--max-`` bar is an upper limit).
BAR_OPTIONS = {
    "--min-f1": "f1",
    "--min-precision": "precision",
    "--min-recall": "recall",
    "--min-ap": "ap",
    "--min-ap50": "ap50",
    "--min-idf1": "idf1",
    "--max-centre-error": "centre_error_p90",
    "--max-radius-error": "radius_error_p90",
    "--max-axis-error": "axis_error_p90",
    "--min-accuracy": "accuracy",
}


def bar_dest(option: str) -> str:
    """The argparse attribute of a bar option (``--min-f1`` -> ``min_f1``)."""
    return option[2:].replace("-", "_")


def bars_asked(args: Any) -> dict[str, float]:
    """The bars given on the command line (parsed options, None where not given) by figure name."""
    values = {option: getattr(args, bar_dest(option), None) for option in BAR_OPTIONS}
    return {BAR_OPTIONS[option]: value for option, value in values.items() if value is not None}


def check_bars(bars: Mapping[str, float], empty: Evaluation, kind: str) -> None:
    """Refuse (one line, before any frame is run) a bar the kind's evaluation does not know; ``empty`` is an
    evaluation of no frames, which names its bars as well as a full one."""
    for name, value in bars.items():
        try:
            empty.below({name: value})
        except KeyError as exc:
            option = next(o for o, n in BAR_OPTIONS.items() if n == name)
            known = f": {exc.args[0]}" if exc.args else ""
            raise UserError(f"{option}: not a figure of the {kind} kind{known}") from None
        except Exception:  # an evaluation of nothing may fail to compare at all: judged after the run instead
            continue


def missed_bars(evaluation: Evaluation, bars: Mapping[str, float]) -> list[str]:
    """One line per bar missed, as the kind words it."""
    if not bars:
        return []
    try:
        return list(evaluation.below(bars))
    except KeyError as exc:
        raise UserError(f"the {evaluation.kind} kind has no figure among {', '.join(bars)} "
                        f"({exc.args[0] if exc.args else ''})") from None


# -- the table ----------------------------------------------------------------------------------------------
def _cell(value: Any) -> tuple[str, bool]:
    """A value as the table shows it, and whether it is a number (right-aligned)."""
    if value is None:
        return "-", True
    if isinstance(value, bool):
        return ("yes" if value else "no"), False
    if isinstance(value, int):
        return str(value), True
    if isinstance(value, float):
        return ("-" if math.isnan(value) else f"{value:.3f}"), True
    return str(value), False


def format_table(rows: Sequence[Mapping[str, Any]], first: str | None = None) -> str:
    """Rows of column -> value as aligned text: text left, numbers right, floats with three decimals."""
    if not rows:
        return "(nothing scored)\n"
    columns: list[str] = []
    for row in rows:
        columns.extend(c for c in row if c not in columns)
    if first is not None and first in columns:
        columns.remove(first)
        columns.insert(0, first)
    cells = [[_cell(row.get(c)) for c in columns] for row in rows]
    numeric = [all(cell[1] for cell in (line[i] for line in cells)) for i in range(len(columns))]
    widths = [max(len(columns[i]), *(len(line[i][0]) for line in cells)) for i in range(len(columns))]

    def line(texts: Sequence[str]) -> str:
        return "  ".join(t.rjust(w) if num else t.ljust(w) for t, w, num in zip(texts, widths, numeric,
                                                                               strict=True)).rstrip()

    return "\n".join([line(columns)] + [line([cell[0] for cell in row]) for row in cells]) + "\n"


# -- the files ------------------------------------------------------------------------------------------------
def _json_ready(value: Any) -> Any:
    """NumPy numbers and arrays as plain JSON (a kind's figures often are)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON-ready")


def make_out_dir(out: Path) -> Path:
    """The output folder, made with its parents if missing; one line if it cannot be."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise UserError(f"--out {out}: exists and is not a folder") from None
    except OSError as exc:
        raise UserError(f"--out {out}: cannot be made: {exc.strerror or exc}") from None
    return out


def write_report(out: Path, evaluation: Evaluation, command: Mapping[str, Any],
                 extra: Mapping[str, Any] | None = None, pictures: bool = True) -> list[Path]:
    """``report.json`` (the evaluation's figures, with ``command``: what was scored and how), ``report.md``
    and the kind's pictures in ``out``; the paths written. Each file is written atomically."""
    make_out_dir(out)
    data = {**evaluation.to_dict(), "command": dict(command), **(extra or {})}
    written = []
    try:
        text = json.dumps(data, indent=2, default=_json_ready, allow_nan=False)
    except ValueError:  # NaN or infinity: JSON has none, so they are written as null
        text = json.dumps(_no_nan(data), indent=2, default=_json_ready)
    write_atomically(out / REPORT_JSON, text + "\n")
    written.append(out / REPORT_JSON)
    write_atomically(out / REPORT_MD, evaluation.markdown().rstrip("\n") + "\n")
    written.append(out / REPORT_MD)
    if pictures:
        try:
            written.extend(evaluation.pictures(out))
        except OutputError:
            raise
        except OSError as exc:
            raise OutputError(out, f"pictures cannot be written: {exc.strerror or exc}") from None
    return written


def _no_nan(value: Any) -> Any:
    if hasattr(value, "tolist"):
        value = value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {k: _no_nan(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_no_nan(v) for v in value]
    return value
