"""Ground truth and scoring, the same for every kind: see :mod:`.truth`, :mod:`.scoring` and :mod:`.run`."""

from .run import Labelled, labelled_frames, load_labelled, saved_pairs, score, score_saved, split
from .scoring import Evaluation, Scorer
from .truth import FrameTruth, KeyedBy, TruthSet

__all__ = ["Evaluation", "FrameTruth", "KeyedBy", "Labelled", "Scorer", "TruthSet", "labelled_frames",
           "load_labelled", "saved_pairs", "score", "score_saved", "split"]
