"""The brute-force candidates come from ``cv2.batchDistance`` on arrays instead of ``BFMatcher.knnMatch``'s DMatch
objects: they must be exactly the matches, distances and order the ratio test on ``knnMatch`` gives."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from objrec2d import DemoScene
from objrec2d.features import FeatureConfig, create_feature2d
from objrec2d.features.matching import TrainedMatcher
from objrec2d.features.types import descriptor_norm

from .conftest import require


def knn_candidates(target: np.ndarray, frame: np.ndarray, norm: int, ratio: float | None) -> tuple[np.ndarray, ...]:
    """What a script writes: knnMatch, then the ratio test over the DMatch objects."""
    matcher = cv2.BFMatcher(norm)
    query, train, distance = [], [], []
    for pair in matcher.knnMatch(frame, target, k=1 if ratio is None else 2):
        kept = bool(pair) if ratio is None else len(pair) == 2 and pair[0].distance < ratio * pair[1].distance
        if not kept:
            continue
        best = pair[0]
        query.append(best.queryIdx)
        train.append(best.trainIdx)
        distance.append(best.distance)
    return np.array(query, np.int32), np.array(train, np.int32), np.array(distance, np.float32)


@pytest.fixture(scope="module")
def scene_images() -> tuple[np.ndarray, tuple[int, int, int, int], list[np.ndarray]]:
    scene = DemoScene(seed=0)
    first, _ = scene.render(0)
    return first, scene.target.reference_rect, [scene.render(9 * i)[0] for i in range(1, 4)]


@pytest.mark.parametrize("feature_type", ["ORB", "SIFT", "BRISK"])
@pytest.mark.parametrize("target_size", [None, 1, 2])  # the whole selection, and fewer descriptors than k
def test_batch_candidates_are_knn_matchs_to_the_last_bit(scene_images, feature_type, target_size):
    require(feature_type)
    first, (x, y, w, h), frames = scene_images
    extractor = create_feature2d(FeatureConfig(type=feature_type))
    _, target = extractor.detectAndCompute(cv2.cvtColor(first, cv2.COLOR_BGR2GRAY)[y:y + h, x:x + w], None)
    target = target[:target_size]
    norm = descriptor_norm(extractor, target)
    matcher = TrainedMatcher(target, norm)
    compared = 0
    for image in frames:
        _, frame = extractor.detectAndCompute(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), None)
        for ratio in (0.8, 0.6, 1.0, None):
            query, train, distance = knn_candidates(target, frame, norm, ratio)
            found = matcher.candidates(frame, ratio)
            assert np.array_equal(found.frame_idx, query), (ratio, len(found), len(query))
            assert np.array_equal(found.target_idx, train)
            assert np.array_equal(found.distance, distance)
            assert found.frame_idx.dtype == np.int32 and found.distance.dtype == np.float32
            compared += len(query)
    if target_size is None:
        assert compared > 500  # real matches were compared, not empty answers
