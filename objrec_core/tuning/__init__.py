"""Tuning a recognition system by numbers: its declared parameters searched for the best score on labelled
frames (``objrec-tune``, the GUI's Tools > Tune).

The stable API::

    from objrec_core.evaluation import load_labelled
    from objrec_core.tuning import tune

    frames = load_labelled(source, truth)                # read once, scored by every trial
    result = tune(system, kind, frames, trials=200, seed=0, held_out=0.3, fix=["blobs.border_blobs"],
                  stop=stop_event, progress=lambda p: print(p.trial, p.best))
    result.score, result.system, result.table()          # held-out score, the tuned copy, what mattered

:mod:`.space` derives the search space from the declarations (no Optuna), :mod:`.search` runs Optuna's TPE
sampler (imported only then: the ``tune`` extra), :mod:`.result` holds what was found.
"""

from .result import TrialRecord, TuningResult
from .search import (
    IMPORTANCE_METHOD,
    NEEDS_EXTRA,
    TuningError,
    TuningProgress,
    TuningUnavailable,
    apply_values,
    copy_system,
    tune,
)
from .space import Dimension, SearchSpace, SearchSpaceError, module_dimensions, search_space, split_name, untuned

__all__ = [
    "IMPORTANCE_METHOD",
    "NEEDS_EXTRA",
    "Dimension",
    "SearchSpace",
    "SearchSpaceError",
    "TrialRecord",
    "TuningError",
    "TuningProgress",
    "TuningResult",
    "TuningUnavailable",
    "apply_values",
    "copy_system",
    "module_dimensions",
    "search_space",
    "split_name",
    "tune",
    "untuned",
]
