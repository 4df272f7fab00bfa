"""Scoring detections against ground truth: the contract every kind's scorer keeps.

A :class:`Scorer` is fed frame by frame (the truth of a frame and what the system detected on it) and then
gives an :class:`Evaluation`: the figures (per object name and in all), the one number tuning maximises
(:attr:`Evaluation.score`), a JSON report, a Markdown report and pictures. What "matched" means is the
kind's: boxes overlapping by IoU for images, centres within a distance for shapes. ``objrec-eval``,
``objrec-tune`` and the GUI's quality strip know only this contract, so a kind of your own that implements
``Kind.read_truth``/``Kind.scorer`` is evaluated and tuned with no change to objrec.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..messages import DetectedObjectArray
from ..sources import Frame
from .truth import FrameTruth


class Evaluation(ABC):
    """What a scorer found over the frames it was fed."""

    #: The data kind ("2d", "3d").
    kind: str = ""
    #: Frames scored.
    frames: int = 0

    @property
    @abstractmethod
    def score(self) -> float:
        """The one figure tuning maximises, in 0..1 (2D: F1 at IoU 0.5 over all names)."""

    @abstractmethod
    def summary_rows(self) -> list[dict[str, Any]]:
        """The summary table: one row per object name and one named "all", column name -> value."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """Everything measured, JSON-ready (``report.json``)."""

    @abstractmethod
    def markdown(self) -> str:
        """A report a person reads (``report.md``): the table, what the figures mean, where the pictures are."""

    def pictures(self, folder: Path) -> list[Path]:
        """Write the pictures a person would rather look at into ``folder``; the paths written."""
        return []

    @abstractmethod
    def below(self, bars: Mapping[str, float]) -> list[str]:
        """The bars this evaluation misses, each as one line (``{"f1": 0.9}`` -> ``f1 0.82 < 0.9``); a bar
        name this kind does not know raises KeyError naming the ones it does."""


class Scorer(ABC):
    """Fed frame by frame, gives an :class:`Evaluation`."""

    @abstractmethod
    def add(self, truth: FrameTruth, detections: DetectedObjectArray, frame: Frame | None = None) -> None:
        """Score one labelled frame: its truth and what was detected on it (``frame`` for pictures)."""

    @abstractmethod
    def result(self) -> Evaluation:
        """The evaluation of every frame added so far."""
