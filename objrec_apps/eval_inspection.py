"""``objrec-eval --inspection REPORT``: an inspection's present/absent/moved verdicts scored against the world.

An inspection world is its own ground truth: every object of the world file stands where the file says,
unless the robot met a changed world (``objrec-inspect --remove NAME``, ``--shift NAME DX DY``); then a
removed object is truly absent and one shifted farther than the verdict's tolerance truly moved (shifted
less, it is still present: the inspection cannot tell and should not). Each verdict of each visit
(``report.json``'s ``visits[].expected[]``) is one judgement; the :class:`Confusion` counts them by true
state (present, absent, moved) and verdict (present, absent, moved, not checked), per object and over the
mission. Its score, the share of judgements that are right, is what tuning would maximise: a verdict not
given (``not_checked``) counts as wrong, so a mission that checks nothing scores 0.

The changes come from ``--remove``/``--shift`` when given, otherwise from the report itself (objrec-inspect
records them in ``changes``), so scoring a report needs nothing but the report and the world file.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navigation.world import World, WorldError, load_world
from objrec_core.evaluation import Evaluation
from strictio import InputError, read_text
from strictio.cli_numbers import Number, fields
from strictio.shown import drawable

from .cli import UserError
from .inspection import InspectionError, changed_world

TRUE_STATES = ("present", "absent", "moved")
VERDICTS = ("present", "absent", "moved", "not_checked")
#: The bars ``below`` knows, and what each measures.
BARS = {
    "accuracy": "right verdicts / verdicts given (not_checked left out)",
    "coverage": "verdicts given / judgements (the share of expected objects checked)",
    "score": "right verdicts / all judgements (not_checked counts as wrong)",
}
#: A report.json is a few hundred visits at most; 64 MB is never a real one.
REPORT_LIMIT = 64 * 1024 * 1024
#: How far --shift may move an object, in metres (as objrec-inspect).
SHIFT = Number(-1000, 1000)

_REMOVED = re.compile(r"^(?P<name>.+) removed$")
_SHIFTED = re.compile(r"^(?P<name>.+) shifted by \((?P<dx>[^,]+), (?P<dy>[^)]+)\) m$")


@dataclass
class Confusion(Evaluation):
    """True state against verdict, per object name: ``counts[name][(truth, verdict)]`` judgements."""

    counts: dict[str, dict[tuple[str, str], int]] = field(default_factory=dict)
    changes: list[str] = field(default_factory=list)
    report: str = ""
    world: str = ""
    kind: str = "inspection"
    frames: int = 0  # visits scored

    def add(self, name: str, truth: str, verdict: str) -> None:
        cell = self.counts.setdefault(name, {})
        cell[(truth, verdict)] = cell.get((truth, verdict), 0) + 1

    def matrix(self, name: str | None = None) -> dict[tuple[str, str], int]:
        """The counts of one object, or of all (``name`` None)."""
        if name is not None:
            return dict(self.counts.get(name, {}))
        total: dict[tuple[str, str], int] = {}
        for cells in self.counts.values():
            for key, n in cells.items():
                total[key] = total.get(key, 0) + n
        return total

    @staticmethod
    def figures(cells: Mapping[tuple[str, str], int]) -> dict[str, Any]:
        judged = sum(cells.values())
        given = sum(n for (_, v), n in cells.items() if v != "not_checked")
        right = sum(n for (t, v), n in cells.items() if t == v)
        missed = sum(n for (t, v), n in cells.items() if t != "present" and v == "present")
        alarms = sum(n for (t, v), n in cells.items() if t == "present" and v in ("absent", "moved"))
        return {"judgements": judged, "checked": given, "right": right,
                "accuracy": right / given if given else 0.0, "coverage": given / judged if judged else 0.0,
                "score": right / judged if judged else 0.0, "missed_changes": missed, "false_alarms": alarms}

    @property
    def score(self) -> float:
        return float(self.figures(self.matrix())["score"])

    def summary_rows(self) -> list[dict[str, Any]]:
        rows = [{"name": name, **self.figures(self.matrix(name))} for name in sorted(self.counts)]
        return [*rows, {"name": "all", **self.figures(self.matrix())}]

    def to_dict(self) -> dict[str, Any]:
        def table(cells: Mapping[tuple[str, str], int]) -> dict[str, dict[str, int]]:
            return {t: {v: cells.get((t, v), 0) for v in VERDICTS} for t in TRUE_STATES}

        return {"kind": self.kind, "report": self.report, "world": self.world, "changes": self.changes,
                "visits": self.frames, "score": self.score, "summary": self.summary_rows(),
                "confusion": {"all": table(self.matrix()),
                              **{name: table(self.matrix(name)) for name in sorted(self.counts)}}}

    def markdown(self) -> str:
        lines = ["# Inspection verdicts against the world", "",
                 f"Report `{self.report}`, {self.frames} visits; truth: the world file `{self.world}`"
                 + (" with " + "; ".join(self.changes) if self.changes else " unchanged") + ".", "",
                 "| object | judgements | checked | right | accuracy | coverage | missed changes | false alarms |",
                 "|---|---|---|---|---|---|---|---|"]
        for r in self.summary_rows():
            lines.append(f"| {r['name']} | {r['judgements']} | {r['checked']} | {r['right']} | "
                         f"{r['accuracy']:.2f} | {r['coverage']:.2f} | {r['missed_changes']} | {r['false_alarms']} |")
        lines += ["", "Accuracy: right verdicts among those given; coverage: the share of expected objects checked; "
                      "missed changes: an absent or moved object reported present; false alarms: a present "
                      "object reported absent or moved.", "", "## Confusion (rows: truth, columns: verdict)", ""]
        for name in ["all", *sorted(self.counts)]:
            cells = self.matrix(None if name == "all" else name)
            lines += [f"**{name}**", "", "| truth \\ verdict | " + " | ".join(v.replace("_", " ") for v in VERDICTS)
                      + " |", "|---|" + "---|" * len(VERDICTS)]
            lines += [f"| {t} | " + " | ".join(str(cells.get((t, v), 0)) for v in VERDICTS) + " |"
                      for t in TRUE_STATES]
            lines.append("")
        return "\n".join(lines)

    def pictures(self, folder: Path) -> list[Path]:
        """``inspection-confusion.png``: the matrix over the mission, each cell shaded by its share of its row
        (green on the diagonal, red off it), then one small matrix per object."""
        import cv2
        import numpy as np

        from strictio import OutputError, write_atomically

        names = ["all", *sorted(self.counts)]
        cell, left, top, gap = 64, 96, 40, 24
        width = left + cell * len(VERDICTS) + 16
        block = top + cell * len(TRUE_STATES) + gap
        img = np.full((block * len(names) + 8, width, 3), 255, np.uint8)
        font = cv2.FONT_HERSHEY_SIMPLEX
        for k, name in enumerate(names):
            y0 = k * block
            cells = self.matrix(None if name == "all" else name)
            cv2.putText(img, drawable(name), (8, y0 + 18), font, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
            cv2.putText(img, "truth \\ verdict", (8, y0 + top - 6), font, 0.35, (60, 60, 60), 1, cv2.LINE_AA)
            for c, verdict in enumerate(VERDICTS):
                cv2.putText(img, drawable(verdict.replace("_", " ")), (left + c * cell + 4, y0 + top - 6), font, 0.38,
                            (60, 60, 60), 1, cv2.LINE_AA)
            for r, truth in enumerate(TRUE_STATES):
                y = y0 + top + r * cell
                cv2.putText(img, drawable(truth), (8, y + cell // 2 + 5), font, 0.45, (60, 60, 60), 1, cv2.LINE_AA)
                row_total = sum(cells.get((truth, v), 0) for v in VERDICTS)
                for c, verdict in enumerate(VERDICTS):
                    n = cells.get((truth, verdict), 0)
                    share = n / row_total if row_total else 0.0
                    hue = np.array((60, 170, 40) if truth == verdict else (40, 40, 220), np.float64)
                    colour = tuple(round(v) for v in 255 - share * (255 - hue))
                    x = left + c * cell
                    cv2.rectangle(img, (x, y), (x + cell - 2, y + cell - 2), colour, -1)
                    cv2.rectangle(img, (x, y), (x + cell - 2, y + cell - 2), (215, 215, 215), 1)
                    cv2.putText(img, drawable(str(n)), (x + cell // 2 - 8, y + cell // 2 + 6), font, 0.6, (0, 0, 0), 1,
                                cv2.LINE_AA)
        path = Path(folder) / "inspection-confusion.png"
        ok, png = cv2.imencode(".png", img)
        if not ok:
            raise OutputError(str(path), "OpenCV cannot encode the picture")
        write_atomically(path, png.tobytes())
        return [path]

    def below(self, bars: Mapping[str, float]) -> list[str]:
        unknown = sorted(set(bars) - set(BARS))
        if unknown:
            raise KeyError(f"no bar {unknown[0]!r} for an inspection (known: {', '.join(BARS)})")
        got = self.figures(self.matrix())
        return [f"{name} {got[name]:.3f} < {bar:g}" for name, bar in bars.items() if got[name] < bar]


def true_state(world: World, name: str, expected: tuple[float, float], tolerance: float) -> str:
    """Where the object really is against where the world file puts it: present, absent or moved."""
    thing = next((o for o in world.objects if o.name == name), None)
    if thing is None:
        return "absent"
    x, y, _ = thing.centre
    return "moved" if math.hypot(x - expected[0], y - expected[1]) > tolerance else "present"


def inspection_confusion(report: Mapping[str, Any] | str | Path, world: World, path: str | Path = "") -> Confusion:
    """The confusion of a report's verdicts (report.json's content, or its path) against ``world``: the world
    the robot met (the world file with the mission's changes applied, :func:`truth_world`). ``path`` names
    the report's file in messages when the content is given."""
    path = str(path)
    if not isinstance(report, Mapping):
        path = str(report)
        report = read_report(report)
    where = path or "report"
    confusion = Confusion(report=path, world=str(world.source or ""))
    visits = _list(report.get("visits"), where, "visits")
    for i, visit in enumerate(visits):
        at = f"visits[{i}]"
        if not isinstance(visit, Mapping):
            raise InputError(where, f"{at}: {_shown(visit)} is not an object")
        for k, e in enumerate(_list(visit.get("expected", []), where, f"{at}.expected")):
            name, status, xy, tolerance = _verdict(e, where, f"{at}.expected[{k}]")
            confusion.add(name, true_state(world, name, xy, tolerance), status)
        confusion.frames += 1
    return confusion


def read_report(path: str | Path) -> dict[str, Any]:
    """An objrec-inspect ``report.json``; an InputError naming the file (and line) when it is not one."""
    text = read_text(path, limit=REPORT_LIMIT)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(str(path), f"line {exc.lineno}: not JSON: {exc.msg}") from None
    if not isinstance(data, dict) or "visits" not in data:
        raise InputError(str(path), "visits: missing: not an objrec-inspect report.json")
    return data


def report_changes(report: Mapping[str, Any], where: str) -> tuple[list[str], list[tuple[str, float, float]]]:
    """The --remove and --shift the report was made with, read back from its ``changes``."""
    removed: list[str] = []
    shifted: list[tuple[str, float, float]] = []
    for i, change in enumerate(_list(report.get("changes", []), where, "changes")):
        text = str(change)
        if m := _REMOVED.match(text):
            removed.append(m["name"])
        elif (m := _SHIFTED.match(text)) and _is_float(m["dx"]) and _is_float(m["dy"]):
            shifted.append((m["name"], float(m["dx"]), float(m["dy"])))
        else:
            raise InputError(where, f"changes[{i}]: {_shown(change)} is neither 'NAME removed' nor "
                                    "'NAME shifted by (DX, DY) m'")
    return removed, shifted


def truth_world(world_path: str | Path, remove: Sequence[str] = (),
                shift: Sequence[tuple[str, float, float]] = ()) -> tuple[World, list[str]]:
    """The world file with objects removed or shifted (what the robot met), and the changes made."""
    try:
        world = load_world(world_path)
        return changed_world(world, remove, shift)
    except (WorldError, InspectionError) as exc:
        raise UserError(f"{world_path}: {exc}" if str(world_path) not in str(exc) else str(exc)) from None


# -- the command's part: objrec-eval --inspection REPORT [--truth WORLD] [--remove ...] [--shift ...] -------
def add_inspection_arguments(parser: argparse.ArgumentParser) -> None:
    """``--inspection``, ``--remove`` and ``--shift`` (the world file is objrec-eval's ``--truth``)."""
    group = parser.add_argument_group(
        "inspection: score an objrec-inspect report's present/absent/moved verdicts against the world file "
        "(--truth WORLD_YAML, default: the report's world)")
    group.add_argument("--inspection", metavar="REPORT_JSON", help="objrec-inspect's report.json")
    group.add_argument("--remove", action="append", default=[], metavar="NAME",
                       help="the robot met the world without this object (repeatable; default: the report's "
                            "recorded changes)")
    group.add_argument("--shift", action=fields(None, SHIFT, SHIFT, append=True), nargs=3, default=[],
                       metavar=("NAME", "DX", "DY"),
                       help="the robot met this object shifted by DX, DY metres (repeatable)")


def refuse_stray_inspection_options(args: argparse.Namespace) -> None:
    """``--remove``/``--shift`` say what the robot met: they mean nothing without ``--inspection``."""
    if not getattr(args, "inspection", None) and (args.remove or args.shift):
        raise UserError(f"{'--remove' if args.remove else '--shift'}: only with --inspection REPORT_JSON (the world "
                        "an inspection met)")


def inspection_command(confusion: Confusion) -> dict[str, Any]:
    """What was scored, for report.json's ``command``."""
    return {"inspection": confusion.report, "truth": confusion.world, "changes": confusion.changes,
            "frames": confusion.frames, "interrupted": False}


def inspection_evaluation(args: argparse.Namespace) -> Confusion:
    """The confusion ``objrec-eval --inspection`` reports; a UserError (one line) for any unusable input."""
    path = Path(args.inspection)
    try:
        report = read_report(path)
        world_path = getattr(args, "truth", None) or report.get("world")
        if not world_path:
            raise UserError(f"{path}: world: the report names no world file; give it with --truth WORLD_YAML")
        if args.remove or args.shift:
            remove, shift = list(args.remove), [(n, float(dx), float(dy)) for n, dx, dy in args.shift]
        else:
            remove, shift = report_changes(report, str(path))
        world, changes = truth_world(world_path, remove, shift)
        confusion = inspection_confusion(report, world, path)
    except InputError as exc:
        raise UserError(str(exc)) from None
    confusion.report, confusion.world, confusion.changes = str(path), str(world_path), changes
    return confusion


# -- reading the report's verdicts --------------------------------------------------------------------------
def _verdict(e: Any, where: str, at: str) -> tuple[str, str, tuple[float, float], float]:
    if not isinstance(e, Mapping):
        raise InputError(where, f"{at}: {_shown(e)} is not an object")
    name, status = e.get("name"), e.get("status")
    if not isinstance(name, str) or not name:
        raise InputError(where, f"{at}.name: {_shown(name)} is not an object name")
    if status not in VERDICTS:
        raise InputError(where, f"{at}.status: {_shown(status)} is not one of {', '.join(VERDICTS)}")
    expected = e.get("expected")
    if not isinstance(expected, Mapping) or not all(_is_number(expected.get(k)) for k in ("x", "y")):
        raise InputError(where, f"{at}.expected: {_shown(expected)} is not a position with x and y")
    tolerance = e.get("tolerance_m")
    if not _is_number(tolerance) or tolerance <= 0:
        raise InputError(where, f"{at}.tolerance_m: {_shown(tolerance)} is not a distance > 0")
    return name, status, (float(expected["x"]), float(expected["y"])), float(tolerance)


def _list(value: Any, where: str, at: str) -> Iterable[Any]:
    if not isinstance(value, list):
        raise InputError(where, f"{at}: {_shown(value)} is not a list")
    return value


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _is_float(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _shown(value: Any) -> str:
    text = json.dumps(value) if not isinstance(value, str) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
