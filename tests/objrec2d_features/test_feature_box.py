"""The classic pair: box.png selected whole and found in box_in_scene.png by ORB, SIFT and AKAZE."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from objrec2d import DetectionStatus, FeatureDetector
from objrec2d.features import corner_error

pytestmark = pytest.mark.realdata

# The box's outline in box_in_scene.png: SIFT's homography, checked by eye on the side-by-side view
# (the box's printed edges lie on it) and agreed on within 3 px by BRISK and KAZE.
BOX_CORNERS = np.array([[118.7, 160.8], [284.8, 174.9], [267.7, 298.3], [89.3, 272.1]])


def overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two convex polygons."""
    a32, b32 = a.astype(np.float32), b.astype(np.float32)
    inter, _ = cv2.intersectConvexConvex(a32, b32)
    return inter / (cv2.contourArea(a32) + cv2.contourArea(b32) - inter)


@pytest.mark.parametrize("matcher", ["brute_force", "flann"])
@pytest.mark.parametrize("feature_type", ["ORB", "SIFT", "AKAZE"])
def test_box_is_found_in_the_scene(box, box_in_scene, require_feature, feature_type, matcher):
    require_feature(feature_type)
    detector = FeatureDetector(feature_type=feature_type, matcher=matcher, object_name="box")
    detector.set_target(box)
    assert detector.target.rect == detector.target.roi  # selected whole: no margin to add
    objects = detector.detect(box_in_scene)
    result = objects.details[0]
    assert result.status is DetectionStatus.FOUND, objects.reason
    assert objects.reason is None
    assert result.inlier_count >= 15
    assert [o.name for o in objects] == ["box"]
    polygon = np.array(objects[0].polygon.xy())
    assert corner_error(polygon, BOX_CORNERS) < 10.0  # the box is about 170 x 125 px in the scene
    assert overlap(polygon, BOX_CORNERS) > 0.9


def test_box_target_is_the_whole_image_with_its_outline(box):
    detector = FeatureDetector()
    detector.set_target(box)
    target = detector.target
    assert target.image.shape == box.shape and np.array_equal(target.image, box)
    np.testing.assert_allclose(target.corners(), [[-0.5, -0.5], [323.5, -0.5], [323.5, 222.5], [-0.5, 222.5]])
    assert len(target) >= 300  # ORB finds plenty on the printed box


def test_box_is_not_found_in_an_image_without_it(box, images):
    detector = FeatureDetector(feature_type="SIFT")
    detector.set_target(box)
    fruits = cv2.imread(str(images / "fruits.jpg"))
    result = detector.detect(fruits)
    assert result == []
    assert result.details[0].status in {
        DetectionStatus.TOO_FEW_MATCHES,
        DetectionStatus.TOO_FEW_INLIERS,
        DetectionStatus.DEGENERATE_POLYGON,
    }
    assert result.reason
