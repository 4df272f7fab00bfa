"""The Markdown report of a 3D evaluation (``report.md``): the tables and what each figure means."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .evaluation import ShapeEvaluation


def cell(value: Any) -> str:
    """A table cell: counts as they are, fractions to three places, metres in millimetres' precision."""
    if value is None:
        return "-"
    if isinstance(value, bool | int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.4g}" if abs(value) < 1e-3 and value else f"{value:.3f}"
    return str(value).replace("|", "\\|")


def table(rows: list[dict[str, Any]]) -> list[str]:
    if not rows:
        return ["(nothing scored)"]
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(cell(row.get(k)) for k in keys) + " |" for row in rows]
    return lines


def markdown(evaluation: ShapeEvaluation) -> str:
    from .evaluation import CONFUSION_COLUMNS, CONFUSION_ROWS

    o = evaluation.options
    lines = [
        "# 3D evaluation", "",
        f"{evaluation.frames} labelled frames; score (F1 over all names) **{evaluation.score:.3f}**.", "",
        *table(evaluation.summary_rows()), "",
        "## What the figures mean", "",
        f"- A detection matches a truth shape when their centres are within max({o['match_distance']:g} m, "
        f"{o['match_share']:g} x the truth's radius) (one-to-one, optimal). A match of the same name is a true "
        "positive (tp); a detection matched to nothing or to another name is a false positive (fp); a truth "
        "shape not matched by its name is a miss (fn).",
        f"- hidden: truth shapes fewer than {o['min_visible']} points of the frame show (within "
        f"{o['visible_tolerance']:g} m of the solid). Missing one is no miss, finding one is not counted.",
        "- centre_error (m), radius_error (detected - true, m; spheres and cylinders) and axis_error (degrees "
        "between the axes, 0..90; cylinders), over the true positives: median and 90th percentile.",
    ]
    if evaluation.tracking is not None:
        t = evaluation.tracking
        lines += [
            "- idf1: the share of sightings carrying their object's one id (one global id assignment); "
            "id_switches: how often an object was matched to another id than the last.", "",
            "## Tracking", "",
            *table([{"idf1": t.idf1, "idp": t.idp, "idr": t.idr, "idtp": t.idtp, "idfp": t.idfp, "idfn": t.idfn,
                     "id_switches": t.id_switches, "truth_tracks": t.truth_tracks, "tracks": t.tracks}]),
        ]
    lines += ["", "## Shape-type confusion (rows: truth, columns: detected)", ""]
    rows = [{"truth": r, **{c: int(evaluation.confusion[i, j]) for j, c in enumerate(CONFUSION_COLUMNS)}}
            for i, r in enumerate(CONFUSION_ROWS)]
    lines += table(rows)
    if evaluation.worst:
        lines += ["", "## Worst frames", ""]
        lines += [f"- frame {w.truth.index if w.truth.index is not None else w.truth.stamp_ns}: "
                  f"{w.errors} misses and false detections" for w in evaluation.worst]
    lines += ["", "Pictures: 3d-errors.png (error histograms), 3d-confusion.png, 3d-worst-N.png (truth green, "
              "detections red).", ""]
    return "\n".join(lines)
