"""objrec2d: image filters and detectors on OpenCV, image sources and the 2D detected-object messages.

Build a pipeline in a script::

    from objrec2d import HSVFilter, MorphologyFilter, BinaryDetector, open_source
    from objrec_core import DetectionDirector, RecognitionSystem
    system = RecognitionSystem([HSVFilter(h_min=100, h_max=130, s_min=120), MorphologyFilter(), BinaryDetector()],
                               object_name="blue")
    for objects in DetectionDirector(system).run(open_source("demo"), max_frames=10):
        print(objects.to_json())
"""

from .annotate import draw_objects
from .base import ImageDetector, ImageFilter, as_bgr, as_gray
from .binary_detector import BinaryDetector
from .demo import DemoObject, DemoScene, DemoTarget
from .feature_detector import FeatureDetector
from .features import DetectionStatus, FeatureConfig, FeatureMatch, FeatureUnavailable, available_feature_types
from .hsv_filter import HSVFilter
from .messages import DetectedObject2D, DetectedObject2DArray, Point32, Polygon
from .morphology_filter import MorphologyFilter
from .sources import CaptureSource, DemoSource, FolderSource, ImageFileSource, open_source, read_image

__all__ = [
    "BinaryDetector",
    "CaptureSource",
    "DemoObject",
    "DemoScene",
    "DemoSource",
    "DemoTarget",
    "DetectedObject2D",
    "DetectedObject2DArray",
    "DetectionStatus",
    "FeatureConfig",
    "FeatureDetector",
    "FeatureMatch",
    "FeatureUnavailable",
    "FolderSource",
    "HSVFilter",
    "ImageDetector",
    "ImageFileSource",
    "ImageFilter",
    "MorphologyFilter",
    "Point32",
    "Polygon",
    "as_bgr",
    "as_gray",
    "available_feature_types",
    "draw_objects",
    "open_source",
    "read_image",
]
