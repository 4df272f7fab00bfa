"""What a tuning search found: the tuned system, its scores, and which parameters mattered."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from declare.parameters import short_repr

from ..evaluation import Evaluation
from ..system import RecognitionSystem
from .space import SearchSpace


@dataclass(frozen=True)
class TrialRecord:
    """One finished trial: its number (1-based), the searched values it tried (``MODULE_ID.PARAMETER``; a
    parameter that did not matter given the others is absent), its score on the searched frames, and the rule
    it broke (then its score is 0), if any."""

    number: int
    values: dict[str, Any]
    score: float
    broken: str | None = None


@dataclass
class TuningResult:
    """The outcome of :func:`objrec_core.tuning.tune`.

    ``system`` is the tuned copy (the caller's system is untouched); ``start`` and ``values`` every parameter
    before and after, keyed ``MODULE_ID.PARAMETER``. ``score`` is the figure to report: the held-out frames'
    score with the best values, or the searched one where none were held out. ``importance`` is each searched
    parameter's share of the score's variance over the trials (``importance_method`` says how), largest first;
    ``history`` every finished trial in order.
    """

    system: RecognitionSystem
    start: dict[str, Any]
    values: dict[str, Any]
    space: SearchSpace
    seed: int
    searched_score: float
    searched_frames: int
    held_out: Evaluation | None
    held_out_frames: int
    trials: int  # trials finished (stopped ones not counted)
    broken: int  # of them, trials whose values broke a declared rule
    best_trial: int  # 1-based
    stopped: bool
    importance: dict[str, float] = field(default_factory=dict)
    importance_method: str = ""
    history: list[TrialRecord] = field(default_factory=list)

    @property
    def held_out_score(self) -> float | None:
        return None if self.held_out is None else float(self.held_out.score)

    @property
    def score(self) -> float:
        """The reported score: held-out where frames were held out, else the searched frames'."""
        held = self.held_out_score
        return self.searched_score if held is None else held

    @property
    def changed(self) -> dict[str, tuple[Any, Any]]:
        """The parameters the search changed: key -> (start, tuned)."""
        return {k: (self.start[k], v) for k, v in self.values.items() if self.start.get(k) != v
                or type(self.start.get(k)) is not type(v)}

    def score_line(self) -> str:
        """One line on the scores, for a summary and a file's description."""
        searched = f"{self.searched_score:.3f} on {self.searched_frames} searched frames"
        if self.held_out is None:
            return f"score {searched} (none held out)"
        return f"held-out score {self.score:.3f} on {self.held_out_frames} frames ({searched})"

    def importance_rows(self) -> list[tuple[str, str, str, str]]:
        """The table of which parameters mattered: (parameter, importance, start, tuned), most important first;
        then the searched parameters the importance does not cover (searched only in some trials)."""
        rows = []
        for key, share in sorted(self.importance.items(), key=lambda kv: (-kv[1], kv[0])):
            module_key = key.removesuffix(" is none")
            rows.append((key, f"{share:.3f}", short_repr(self.start.get(module_key)),
                         short_repr(self.values.get(module_key))))
        covered = {k.removesuffix(" is none") for k in self.importance}
        for key in self.space.keys:
            if key not in covered:
                rows.append((key, "-", short_repr(self.start.get(key)), short_repr(self.values.get(key))))
        return rows

    def table(self) -> str:
        """The importance table as aligned text, under a line saying how it was computed."""
        headings = ("parameter", "importance", "start", "tuned")
        rows = [headings, *self.importance_rows()]
        widths = [max(len(r[c]) for r in rows) for c in range(4)]
        lines = ["  ".join(cell.rjust(widths[c]) if c == 1 else cell.ljust(widths[c])
                           for c, cell in enumerate(row)).rstrip() for row in rows]
        how = (f"importance: {self.importance_method}, over {self.trials} trials" if self.importance
               else "importance: not measured (fewer than two finished trials, or all scored the same)")
        return how + "\n" + "\n".join(lines) + "\n"

    def description(self, source: str, truth: str | None) -> str:
        """What a tuned parameter file says it was tuned on: the source, the label file (None: the source's own
        truth), trials, seed and scores; no date, so that one seed gives one file."""
        stopped = ", stopped early" if self.stopped else ""
        labels = f"the labels {truth}" if truth else "its own truth"
        return (f"Tuned by objrec-tune on {source} with {labels}: {self.trials} trials "
                f"(best: trial {self.best_trial}{stopped}), seed {self.seed}; {self.score_line()}.")
