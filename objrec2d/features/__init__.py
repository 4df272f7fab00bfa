"""The parts of the feature detector, one job each: feature types and their OpenCV 4/5 factories
(``types``), matchers (``matching``), the homography and its sanity checks (``geometry``), the target
(``target``) and its simulated oblique views (``view_synthesis``), one frame's outcome (``result``) and the
debug views (``debug``)."""

from .debug import keypoints_view, side_by_side
from .geometry import (
    HOMOGRAPHY_METHODS,
    PolygonLimits,
    check_quadrilateral,
    corner_error,
    inside_convex,
    overlap,
    rect_corners,
    unavailable_homography_methods,
)
from .matching import MATCHERS, Matches, TrainedMatcher
from .result import DetectionStatus, FeatureMatch, Instance
from .target import Target, TargetError, target_from_state, target_to_state
from .types import (
    FEATURE_TYPES,
    FeatureConfig,
    FeatureUnavailable,
    available_feature_types,
    create_feature2d,
    types_using,
    unavailable_feature_types,
    unavailable_reason,
)

__all__ = [
    "FEATURE_TYPES",
    "HOMOGRAPHY_METHODS",
    "MATCHERS",
    "DetectionStatus",
    "FeatureConfig",
    "FeatureMatch",
    "FeatureUnavailable",
    "Instance",
    "Matches",
    "PolygonLimits",
    "Target",
    "TargetError",
    "TrainedMatcher",
    "available_feature_types",
    "check_quadrilateral",
    "corner_error",
    "create_feature2d",
    "inside_convex",
    "keypoints_view",
    "overlap",
    "rect_corners",
    "side_by_side",
    "target_from_state",
    "target_to_state",
    "types_using",
    "unavailable_feature_types",
    "unavailable_homography_methods",
    "unavailable_reason",
]
