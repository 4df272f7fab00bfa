"""What one frame's detection attempt found: the outcome, the reason where nothing was reported, and
the keypoints, matches and homography behind it (for the debug views and for people asking why)."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from .matching import Matches


class DetectionStatus(enum.Enum):
    """Why an object was, or was not, reported. find-object reports the same distinctions."""

    FOUND = "found"
    NO_TARGET = "no target"
    TOO_FEW_KEYPOINTS = "too few keypoints"
    TOO_FEW_MATCHES = "too few matches"
    NO_HOMOGRAPHY = "no homography"
    TOO_FEW_INLIERS = "too few inliers"
    BUNCHED_INLIERS = "inliers bunched"
    DEGENERATE_POLYGON = "degenerate polygon"


@dataclass(frozen=True)
class Instance:
    """One copy of the target found in a frame: its matches, their inlier mask, the homography, the
    projected outline and the share of the target its inliers span."""

    matches: Matches
    inliers: np.ndarray  # per match
    homography: np.ndarray
    quadrilateral: np.ndarray
    coverage: float

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


@dataclass(frozen=True)
class FeatureMatch:
    """One frame's attempt. Frozen and replaced per frame, so a view reads a consistent one."""

    status: DetectionStatus
    reason: str | None  # None when found; otherwise a sentence for the user
    frame_shape: tuple[int, ...] = ()
    frame_points: np.ndarray = field(default_factory=lambda: np.empty((0, 2), np.float32))
    matches: Matches = field(default_factory=Matches.empty)
    inliers: np.ndarray = field(default_factory=lambda: np.empty(0, bool))  # per match
    homography: np.ndarray | None = None
    quadrilateral: np.ndarray | None = None  # the projected selection, also when it was rejected
    coverage: float | None = None  # the share of the target the inliers span, where it was measured
    # Every copy found, best first; the fields above describe the first (or the failed attempt).
    instances: tuple[Instance, ...] = ()
    # Why no further copy was reported after the last one found (None where max_instances was reached).
    next_reason: str | None = None

    @property
    def found(self) -> bool:
        return self.status is DetectionStatus.FOUND

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())
