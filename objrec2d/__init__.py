"""objrec2d: the ``2d`` data kind: image filters and detectors on OpenCV, image sources and the 2D
detected-object messages.

Build a pipeline in a script::

    from objrec2d import HSVFilter, MorphologyFilter, BinaryDetector, open_source
    from objrec_core import DetectionDirector, RecognitionSystem
    system = RecognitionSystem([HSVFilter(h_min=100, h_max=130, s_min=120), MorphologyFilter(), BinaryDetector()],
                               object_name="blue")
    for objects in DetectionDirector(system).run(open_source("demo:frames=10")):
        print(objects.to_json())

The apps reach all of this through the kind contract (``objrec_core.get_kind("2d")``, ``open_source(spec,
"2d")``) and the entry points; this package imports neither Qt nor the 3D kind, nor ``objrec_ros``: the bag
source (``objrec2d.bag_source``) is not imported here, and the registry reaches it through its declaration
(``objrec2d.bag_declaration``) only when a spec names a bag, so a 2D run loads no ROS code.
"""

from .annotate import draw_objects
from .base import ImageDetector, ImageFilter, as_bgr, as_gray
from .binary_detector import BinaryDetector
from .demo import DemoObject, DemoScene, DemoTarget
from .feature_detector import FeatureDetector
from .features import DetectionStatus, FeatureConfig, FeatureMatch, FeatureUnavailable, available_feature_types
from .hsv_filter import HSVFilter
from .kind import ImageKind
from .messages import DetectedObject2D, DetectedObject2DArray, Point32, Polygon
from .morphology_filter import MorphologyFilter
from .sources import (
    CameraSource,
    CaptureSource,
    DemoSource,
    FolderSource,
    ImageFileSource,
    VideoSource,
    open_source,
    read_image,
)
from .white_balance_filter import WhiteBalanceFilter

__all__ = [
    "BinaryDetector",
    "CameraSource",
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
    "ImageKind",
    "MorphologyFilter",
    "Point32",
    "Polygon",
    "VideoSource",
    "WhiteBalanceFilter",
    "as_bgr",
    "as_gray",
    "available_feature_types",
    "draw_objects",
    "open_source",
    "read_image",
]
