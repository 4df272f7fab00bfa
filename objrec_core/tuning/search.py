"""The tuning search: Optuna's TPE sampler over a system's declared space, scored on labelled frames.

``tune`` is the one entry point, for ``objrec-tune`` and the GUI's Tools > Tune alike:

- the system is copied (through its parameter file, so the caller's system never changes, and the GUI may go
  on showing it), and each trial sets a complete value set on the copy's modules;
- the labelled frames are split once (``objrec_core.evaluation.split``): the searched share is scored by
  every trial, the held-out share only once, with the best values, and that is the reported score, since a
  search that saw the frames flatters itself on them;
- a trial whose values break a declared rule (``min_radius`` above ``max_radius``) scores 0 and is marked
  infeasible for the sampler (``Trial.set_constraint``, which TPE reads), which learns to avoid the region;
- the first trial is the system's own values where they lie in the space, so the best is never worse than
  the start on the searched frames;
- one seed gives one result: the sampler is seeded, trials run one at a time (``n_jobs=1``) and scoring is
  deterministic. ``timeout`` (wall-clock) and ``stop`` end the search early, and so give up that promise;
- parameter importance is PED-ANOVA's (``optuna.importance.PedAnovaImportanceEvaluator``: which parameters it
  took to reach the best tenth of the scores, from Parzen estimators of the trials). It involves no random
  draws, so it too is the same for the same trials; fANOVA, Optuna's default, would need scikit-learn.

Optuna is imported only when a search starts: without the ``tune`` extra, ``TuningUnavailable`` says what to
install.
"""

from __future__ import annotations

import contextlib
import logging
import tempfile
import threading
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from declare.parameters import ParameterError

from ..evaluation import Evaluation, Labelled, score, split
from ..kinds import Kind
from ..registry import get_kind
from ..storage import ParameterStorage, build_system
from ..system import RecognitionSystem
from .result import TrialRecord, TuningResult
from .space import Dimension, SearchSpace, search_space, trial_values

log = logging.getLogger(__name__)

#: What a missing extra says (the command prints it as its one error line).
NEEDS_EXTRA = "objrec-tune needs the tune extra: pip install 'objrec[tune]'"
#: The constraint a trial breaking a declared rule violates.
RULES = "declared rules"
#: The importance evaluator, as the result names it.
IMPORTANCE_METHOD = ("PED-ANOVA (optuna.importance.PedAnovaImportanceEvaluator): the share each parameter has "
                     "in reaching the best tenth of the scores; deterministic")


class TuningUnavailable(ImportError):
    """Optuna is not installed (the ``tune`` extra)."""


class TuningError(ValueError):
    """A search that cannot start: no labelled frames, nothing to search, a bad share or count."""


@dataclass(frozen=True)
class TuningProgress:
    """What ``progress`` hears after each trial: its number (1-based), the planned count, its score (None for a
    trial that broke a rule or was stopped), the best so far, and how many trials broke a rule."""

    trial: int
    trials: int
    score: float | None
    best: float | None
    broken: int


def _optuna() -> Any:
    try:
        import optuna
    except ImportError:
        raise TuningUnavailable(NEEDS_EXTRA) from None
    return optuna


def copy_system(system: RecognitionSystem) -> RecognitionSystem:
    """An independent copy of ``system`` (modules, values, state, names), made through its parameter file: the
    one way a system is written and read, so the copy is exactly what a saved file would build."""
    with tempfile.TemporaryDirectory(prefix="objrec-tune-") as folder:
        path = Path(folder) / "system.yaml"
        ParameterStorage(system).save_parameters(path)
        return build_system(path)


def _starts(system: RecognitionSystem) -> dict[str, dict[str, Any]]:
    return {m.id: m.get_parameters() for m in system.modules}


def apply_values(system: RecognitionSystem, values: Mapping[str, Mapping[str, Any]]) -> None:
    """Set complete values on each module, all checked (declarations and rules) before any is applied: a
    ParameterError leaves every module as it was."""
    checked = []
    for module in system.modules:
        wanted = values.get(module.id)
        if wanted is None:
            continue
        clean = module.validate_parameters(wanted)
        module.check_values({**module.get_parameters(), **clean})
        checked.append((module, clean))
    for module, clean in checked:
        module.set_parameters(**clean)


def _suggest(trial: Any, dim: Dimension, values: Mapping[str, Any]) -> Any:
    """One dimension's value from an Optuna trial (None through the switch of an optional number)."""
    if dim.kind == "choice":
        return trial.suggest_categorical(dim.key, list(dim.choices))
    if dim.none_switch and trial.suggest_categorical(dim.none_key, [False, True]):
        return None
    assert dim.low is not None and dim.high is not None
    if dim.kind == "int":
        return trial.suggest_int(dim.key, int(dim.low), int(dim.high), step=int(dim.step or 1), log=dim.log)
    return dim.snap(trial.suggest_float(dim.key, dim.low, dim.high, step=dim.step, log=dim.log))


def _start_params(space: SearchSpace, start: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The start values as Optuna parameters, for those that lie in the space (a typed value past a soft bound
    does not: the sampler draws that one)."""
    params: dict[str, Any] = {}
    for dim in space.dimensions:
        value = start[dim.module_id][dim.parameter]
        if dim.kind == "choice":
            if any(value is c or (value == c and type(value) is type(c)) for c in dim.choices):
                params[dim.key] = value
            continue
        if dim.none_switch:
            params[dim.none_key] = value is None
            if value is None:
                continue
        assert dim.low is not None and dim.high is not None
        if dim.low <= value <= dim.high and dim.snap(value) == value:
            params[dim.key] = value
    return params


@contextlib.contextmanager
def _quiet(optuna: Any) -> Iterator[None]:
    """Optuna's per-trial log lines and experimental-feature warnings kept out of a command's stderr (both
    settings are process-wide, as Python's warnings filters are: for the search's duration, whatever thread
    runs it)."""
    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            # PED-ANOVA's reminder that it ranks low values first: the score is negated for it (see _importance)
            warnings.filterwarnings("ignore", "PedAnovaImportanceEvaluator computes", UserWarning)
            warnings.filterwarnings("ignore", "Target and region quantiles select the same set", UserWarning)
            yield
    finally:
        optuna.logging.set_verbosity(verbosity)


def tune(system: RecognitionSystem, kind: Kind | str, frames: Sequence[Labelled], trials: int, seed: int = 0,
         held_out: float = 0.3, fix: Iterable[str] = (), stop: threading.Event | None = None,
         progress: Callable[[TuningProgress], None] | None = None, *, search: Iterable[str] | None = None,
         timeout: float | None = None, scorer_options: Mapping[str, Any] | None = None) -> TuningResult:
    """Search ``system``'s declared parameters for the best score on ``frames`` (labelled frames, loaded once
    with ``objrec_core.evaluation.load_labelled``) and return a :class:`TuningResult` holding the tuned copy.

    ``trials``: how many parameter sets to try. ``seed``: the sampler's and the split's. ``held_out``: the share
    of frames never searched, scored once with the best values (0 holds none out: the reported score is then
    the searched one). ``fix``: names (``MODULE_ID.PARAMETER``, or a module id for all of its parameters) kept
    at their values; ``search``: where given, only these are searched. ``stop`` ends the search after the
    trial under way (whose partial score is dropped); the best so far is kept and still scored on the held-out
    frames. ``progress`` hears a :class:`TuningProgress` after each trial (called in the search's thread).
    ``timeout``: seconds of wall-clock time at most for the search. ``scorer_options`` go to the kind's scorer.

    Raises TuningUnavailable without Optuna, TuningError or ``space.SearchSpaceError`` for a search that cannot
    start. ``system`` itself never changes.
    """
    optuna = _optuna()
    kind = get_kind(kind) if isinstance(kind, str) else kind
    if not 0.0 <= held_out < 1.0:
        raise TuningError(f"held-out share {held_out!r} must be at least 0 and below 1")
    if trials < 1:
        raise TuningError(f"trials {trials!r} must be at least 1")
    if not frames:
        raise TuningError("no labelled frames to tune on")
    if held_out > 0.0 and len(frames) < 2:
        raise TuningError(f"{len(frames)} labelled frame cannot be split into searched and held-out frames: label "
                          "more, or hold none out (held-out share 0)")
    tuned = copy_system(system)
    space = search_space(tuned.modules, fix, search)
    if not space.dimensions:
        raise TuningError("nothing to search: every parameter is fixed, untuned or of a type the search skips")
    searched, kept_out = split(frames, held_out, seed) if held_out > 0.0 else (list(frames), [])
    start = _starts(tuned)
    options = dict(scorer_options or {})
    stop = stop if stop is not None else threading.Event()
    counts = {"broken": 0, "done": 0}
    best: list[float] = []

    def objective(trial: Any) -> float:
        values = trial_values(space, start, lambda dim, current: _suggest(trial, dim, current))
        try:
            apply_values(tuned, values)
        except ParameterError as exc:
            trial.set_user_attr("broken", str(exc))
            trial.set_constraint(RULES, 1.0)  # infeasible: the sampler learns to avoid the region
            counts["broken"] += 1
            return 0.0
        trial.set_constraint(RULES, 0.0)
        evaluation = score(tuned, kind, searched, stop=stop, **options)
        if stop.is_set():
            raise optuna.TrialPruned("stopped")
        return float(evaluation.score)

    def after(study: Any, trial: Any) -> None:
        if trial.state == optuna.trial.TrialState.PRUNED:  # stopped under way: not a trial that counts
            study.stop()
            return
        counts["done"] += 1
        value = trial.value if trial.state == optuna.trial.TrialState.COMPLETE else None
        if value is not None and not trial.user_attrs.get("broken"):
            best[:] = [max(best[0], value)] if best else [value]
        else:
            value = None
        if progress is not None:
            progress(TuningProgress(counts["done"], trials, value, best[0] if best else None, counts["broken"]))
        if stop.is_set():
            study.stop()

    with _quiet(optuna):
        sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, group=True)
        study = optuna.create_study(direction="maximize", sampler=sampler)
        study.enqueue_trial(_start_params(space, start), skip_if_exists=False)
        if not stop.is_set():
            study.optimize(objective, n_trials=trials, timeout=timeout, n_jobs=1, callbacks=[after],
                           gc_after_trial=False, show_progress_bar=False)
        return _finish(optuna, study, tuned, kind, space, start, searched, kept_out, seed, stop, options)


def _finish(optuna: Any, study: Any, tuned: RecognitionSystem, kind: Kind, space: SearchSpace,
            start: Mapping[str, Mapping[str, Any]], searched: list[Labelled], kept_out: list[Labelled], seed: int,
            stop: threading.Event, options: Mapping[str, Any]) -> TuningResult:
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    feasible = [t for t in complete if not t.user_attrs.get("broken")]
    if not feasible:
        raise TuningError("no trial finished with values the rules allow" if complete else
                          "stopped before any trial finished")
    best = max(feasible, key=lambda t: (t.value, -t.number))  # the first of equal scores
    values = trial_values(space, start, lambda dim, current: _from_params(dim, best.params, current))
    apply_values(tuned, values)
    held: Evaluation | None = score(tuned, kind, kept_out, **options) if kept_out else None
    return TuningResult(
        system=tuned, start=_flat(start), values=_flat(values), space=space, seed=seed,
        searched_score=float(best.value), searched_frames=len(searched), held_out=held,
        held_out_frames=len(kept_out), trials=len(complete), broken=len(complete) - len(feasible),
        best_trial=best.number + 1, stopped=stop.is_set(), importance=_importance(optuna, study),
        importance_method=IMPORTANCE_METHOD, history=[_record(space, t) for t in complete])


def _record(space: SearchSpace, trial: Any) -> TrialRecord:
    """A finished trial's searched values as it applied them; those it did not draw (irrelevant) left out."""
    values = {dim.key: _from_params(dim, trial.params, {dim.parameter: None}) for dim in space.dimensions
              if dim.key in trial.params or trial.params.get(dim.none_key)}
    return TrialRecord(trial.number + 1, values, float(trial.value), trial.user_attrs.get("broken"))


def _from_params(dim: Dimension, params: Mapping[str, Any], current: Mapping[str, Any]) -> Any:
    """A finished trial's value of one dimension, as the trial applied it (snapped to the grid)."""
    if dim.none_switch and params.get(dim.none_key):
        return None
    if dim.key not in params:
        return current[dim.parameter]
    return params[dim.key] if dim.kind == "choice" else dim.snap(params[dim.key])


def _flat(values: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    return {f"{module_id}.{name}": value for module_id, v in values.items() for name, value in v.items()}


def _importance(optuna: Any, study: Any) -> dict[str, float]:
    """PED-ANOVA's importance per searched parameter, normalized to sum to 1; empty when the trials cannot tell
    (fewer than two, or all the same score)."""
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    if len(complete) < 2 or len({t.value for t in complete}) < 2:
        return {}
    evaluator = optuna.importance.PedAnovaImportanceEvaluator()
    try:  # PED-ANOVA takes lower as better: the score is negated
        found = optuna.importance.get_param_importances(study, evaluator=evaluator, target=lambda t: -t.value)
    except (RuntimeError, ValueError) as exc:  # no parameter common to every trial
        log.info("no parameter importance: %s", exc)
        return {}
    return {name: float(value) for name, value in found.items()}
