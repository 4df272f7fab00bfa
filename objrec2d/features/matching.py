"""Descriptor matching: a matcher trained on the target's descriptors, the ratio test and the cross check.

The norm follows the descriptor: Hamming for binary descriptors, L2 for float ones. FLANN gets an LSH index
for binary descriptors and KD-trees for float ones; KD-trees on binary descriptors crash or return
nonsense, which is why the index is never chosen by hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from .types import is_binary_norm

MATCHERS: tuple[str, ...] = ("brute_force", "flann")

# FLANN index algorithms (flann::flann_algorithm_t); the Python bindings take them as plain numbers.
_FLANN_KDTREE = 1
_FLANN_LSH = 6


@dataclass(frozen=True)
class Matches:
    """Matched pairs as parallel arrays: frame keypoint index, target keypoint index, descriptor distance."""

    frame_idx: np.ndarray
    target_idx: np.ndarray
    distance: np.ndarray

    def __len__(self) -> int:
        return len(self.frame_idx)

    @classmethod
    def empty(cls) -> Matches:
        none = np.empty(0, dtype=np.int32)
        return cls(none, none, np.empty(0, dtype=np.float32))


def _flann_matcher(binary: bool) -> Any:
    if binary:
        index = {"algorithm": _FLANN_LSH, "table_number": 6, "key_size": 12, "multi_probe_level": 1}
    else:
        index = {"algorithm": _FLANN_KDTREE, "trees": 4}
    return cv2.FlannBasedMatcher(index, {"checks": 50})


def _check_descriptors(descriptors: np.ndarray, binary: bool, what: str) -> np.ndarray:
    expected = np.uint8 if binary else np.float32
    if descriptors.dtype != expected:
        kind = "binary (uint8)" if binary else "float (float32)"
        raise ValueError(
            f"{what} descriptors are {descriptors.dtype}, but the matcher was trained on {kind} ones: "
            "they come from different feature types and cannot be compared"
        )
    return descriptors


class TrainedMatcher:
    """A brute-force or FLANN matcher trained once on the target's descriptors, then queried per frame."""

    def __init__(self, target_descriptors: np.ndarray, norm: int, kind: str = "brute_force") -> None:
        if kind not in MATCHERS:
            raise ValueError(f"unknown matcher {kind!r} (known: {', '.join(MATCHERS)})")
        self.kind = kind
        self.norm = norm
        self.binary = is_binary_norm(norm)
        self.target_descriptors = _check_descriptors(target_descriptors, self.binary, "target")
        self._matcher = cv2.BFMatcher(norm) if kind == "brute_force" else _flann_matcher(self.binary)
        # The distance type BFMatcher computes in: integers for Hamming (and L1 on bytes), floats otherwise.
        integer = self.binary or (norm == cv2.NORM_L1 and self.target_descriptors.dtype == np.uint8)
        self._distance_type = cv2.CV_32S if integer else cv2.CV_32F
        self._matcher.add([self.target_descriptors])
        self._matcher.train()

    def match(self, frame_descriptors: np.ndarray, ratio: float | None, cross_check: bool) -> Matches:
        """Match every frame descriptor against the target.

        ``ratio``: keep a match only when its distance is below ``ratio`` times the second-nearest one
        (Lowe's test; None switches it off). ``cross_check``: keep it only when the frame keypoint is also
        the target keypoint's nearest neighbour in the frame. Always one-to-one: where several frame
        keypoints take the same target keypoint, the closest wins, so no target point is counted twice
        as an inlier.
        """
        candidates = self.candidates(frame_descriptors, ratio)
        return self.select(candidates, frame_descriptors, cross_check)

    def candidates(self, frame_descriptors: np.ndarray, ratio: float | None) -> Matches:
        """Each frame keypoint's nearest target keypoint that passes the ratio test; not yet one-to-one.

        These depend on each frame keypoint alone, so a detector looking for several copies of the target
        computes them once per frame and runs ``select`` on what is left after each copy."""
        if frame_descriptors is None or len(frame_descriptors) == 0 or len(self.target_descriptors) == 0:
            return Matches.empty()
        frame_descriptors = _check_descriptors(frame_descriptors, self.binary, "frame")
        if self.kind == "brute_force":
            return self._nearest(frame_descriptors, ratio)
        # FLANN answers with one DMatch object per neighbour; three plain lists filled in one pass (a table of
        # tuples made into an array cost twice the time).
        query: list[int] = []
        train: list[int] = []
        distance: list[float] = []
        if ratio is not None:
            for pair in self._matcher.knnMatch(frame_descriptors, k=2):
                if len(pair) == 2:
                    best, second = pair
                    if best.distance < ratio * second.distance:
                        query.append(best.queryIdx)
                        train.append(best.trainIdx)
                        distance.append(best.distance)
        else:
            for pair in self._matcher.knnMatch(frame_descriptors, k=1):
                if pair:
                    query.append(pair[0].queryIdx)
                    train.append(pair[0].trainIdx)
                    distance.append(pair[0].distance)
        if not query:
            return Matches.empty()
        return Matches(np.array(query, np.int32), np.array(train, np.int32), np.array(distance, np.float32))

    def _nearest(self, frame_descriptors: np.ndarray, ratio: float | None) -> Matches:
        """The brute-force candidates as arrays: ``cv2.batchDistance``, the very call ``BFMatcher.knnMatch`` makes
        (same norm, same distance type, same order and ties), without a DMatch object per neighbour and the
        Python loop that reads them back (about 0.4 ms of a busy VGA frame's ORB; benchmarks/bench_feature.py)."""
        k = 1 if ratio is None else 2
        distances, nearest = cv2.batchDistance(
            frame_descriptors, self.target_descriptors, self._distance_type, normType=self.norm, K=k
        )
        if nearest.ndim != 2 or nearest.shape[1] < k:  # fewer target descriptors than neighbours asked for
            return Matches.empty()
        if ratio is None:
            keep = nearest[:, 0] >= 0
        else:  # compared in double precision, as the DMatch floats were (both columns converted in one call)
            both = distances.astype(np.float64)
            keep = both[:, 0] < ratio * both[:, 1]
            if self._distance_type != cv2.CV_32S:  # integer distances never miss a neighbour: K <= targets here
                keep &= nearest[:, 1] >= 0  # a float one can (a NaN distance is never nearer than any)
        query = keep.nonzero()[0]
        if len(query) == 0:
            return Matches.empty()
        # The indices are int32 already (CV_32S), the distances float32 only for float descriptors: no copies.
        return Matches(query.astype(np.int32), nearest[query, 0].astype(np.int32, copy=False),
                       distances[query, 0].astype(np.float32, copy=False))

    def select(
        self,
        candidates: Matches,
        frame_descriptors: np.ndarray,
        cross_check: bool,
        available: np.ndarray | None = None,
    ) -> Matches:
        """The one-to-one matches among ``candidates`` whose frame keypoint is ``available`` (a mask over
        the frame keypoints; all where None). The cross check looks only at available frame keypoints, so
        a copy of the target already found does not take the best match of the next one."""
        frame_idx, target_idx, distance = candidates.frame_idx, candidates.target_idx, candidates.distance
        if available is not None and len(frame_idx):
            keep = available[frame_idx]
            frame_idx, target_idx, distance = frame_idx[keep], target_idx[keep], distance[keep]
        if len(frame_idx) == 0:
            return Matches.empty()
        # One frame keypoint per target keypoint: sort by target then distance, keep each target's first.
        order = np.lexsort((distance, target_idx))
        ordered = target_idx[order]
        first = np.empty(len(order), dtype=bool)
        first[0] = True
        np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
        keep = order[first]
        frame_idx, target_idx, distance = frame_idx[keep], target_idx[keep], distance[keep]
        if cross_check:
            mutual = self._reverse_best(frame_descriptors, available)[target_idx] == frame_idx
            frame_idx, target_idx, distance = frame_idx[mutual], target_idx[mutual], distance[mutual]
        return Matches(frame_idx, target_idx, distance)

    def _reverse_best(self, frame_descriptors: np.ndarray, available: np.ndarray | None = None) -> np.ndarray:
        """For each target descriptor, the index of its nearest available frame descriptor (-1 where none)."""
        best = np.full(len(self.target_descriptors), -1, dtype=np.int32)
        frame_descriptors = _check_descriptors(frame_descriptors, self.binary, "frame")
        index = np.arange(len(frame_descriptors), dtype=np.int32)
        if available is not None:
            index = index[available]
            frame_descriptors = frame_descriptors[available]
        if len(frame_descriptors) == 0:
            return best
        if self.kind == "brute_force":
            reverse = cv2.BFMatcher(self.norm).match(self.target_descriptors, frame_descriptors)
        else:
            reverse = _flann_matcher(self.binary).match(self.target_descriptors, frame_descriptors)
        for m in reverse:
            best[m.queryIdx] = index[m.trainIdx]
        return best
