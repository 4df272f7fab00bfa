"""objrec3d: the ``3d`` data kind: point clouds in, spheres and cylinders out as oriented boxes.

The cloud type (``PointCloud``), its sources (``open_source``: ``demo``, .pcd/.ply files and folders,
``rgbd:`` colour and depth pairs, ``realsense``), the modules ``DistanceFilter``, ``VoxelFilter``,
``PlaneRemovalFilter`` and ``ShapeDetector``, the ``DetectedObject3D`` messages and the kind itself
(``CloudKind``). PCD and PLY files are read by NumPy through strictio (``pcd.py``, ``ply.py``); Open3D is
imported only where a conversion or an RGB-D or RealSense read needs it, OpenCV only to draw ``--annotate``
pictures; Qt and the 2D kind never.
"""

from .base import CloudDetector, CloudFilter
from .cloud import PointCloud, as_cloud
from .demo import DemoShape, DemoTruth, SceneOptions, demo_scene, random_options, render_scene
from .distance_filter import DistanceFilter
from .fitting import PlaneFit, ShapeFit, fit_plane
from .kind import CloudKind
from .messages import DetectedObject3D, DetectedObject3DArray, OrientedBox, Point, Pose, Quaternion
from .normals import estimate_normals, grid_normals, knn_normals
from .pcd import CloudFileError, read_pcd, write_pcd
from .plane_removal_filter import PlaneRemovalFilter
from .ply import read_ply
from .shape_detector import ShapeDetector
from .sources import DemoSource, FileSource, RealSenseSource, RGBDSource, open_source, read_cloud
from .tracking import IdentityTracker
from .voxel_filter import VoxelFilter

__all__ = [
    "CloudDetector",
    "CloudFileError",
    "CloudFilter",
    "CloudKind",
    "DemoShape",
    "DemoSource",
    "DemoTruth",
    "DetectedObject3D",
    "DetectedObject3DArray",
    "DistanceFilter",
    "FileSource",
    "IdentityTracker",
    "OrientedBox",
    "PlaneFit",
    "PlaneRemovalFilter",
    "Point",
    "PointCloud",
    "Pose",
    "Quaternion",
    "RGBDSource",
    "RealSenseSource",
    "SceneOptions",
    "ShapeDetector",
    "ShapeFit",
    "VoxelFilter",
    "as_cloud",
    "demo_scene",
    "estimate_normals",
    "fit_plane",
    "grid_normals",
    "knn_normals",
    "open_source",
    "random_options",
    "read_cloud",
    "read_pcd",
    "read_ply",
    "render_scene",
    "write_pcd",
]
