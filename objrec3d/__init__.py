"""objrec3d: point clouds in, spheres and cylinders out as oriented boxes.

The cloud type (``PointCloud``), its sources (``open_source``: demo, .pcd/.ply files and folders, RGB-D pairs,
RealSense), the modules ``DistanceFilter``, ``VoxelFilter``, ``PlaneRemovalFilter`` and ``ShapeDetector``, and
the ``DetectedObject3D`` messages. Open3D is imported only where a conversion or a PLY/RGB-D read needs it.
"""

from .base import CloudDetector, CloudFilter
from .cloud import PointCloud, as_cloud
from .demo import DemoTruth, SceneOptions, TruthShape, demo_scene, random_options, render_scene
from .distance_filter import DistanceFilter
from .fitting import PlaneFit, ShapeFit, fit_plane
from .messages import DetectedObject3D, DetectedObject3DArray, OrientedBox, Point, Pose, Quaternion
from .normals import estimate_normals, grid_normals, knn_normals
from .pcd import CloudFileError, read_pcd, write_pcd
from .plane_removal_filter import PlaneRemovalFilter
from .shape_detector import ShapeDetector
from .sources import open_source, read_cloud, read_ply
from .voxel_filter import VoxelFilter

__all__ = [
    "CloudDetector",
    "CloudFileError",
    "CloudFilter",
    "DemoTruth",
    "DetectedObject3D",
    "DetectedObject3DArray",
    "DistanceFilter",
    "OrientedBox",
    "PlaneFit",
    "PlaneRemovalFilter",
    "Point",
    "PointCloud",
    "Pose",
    "Quaternion",
    "SceneOptions",
    "ShapeDetector",
    "ShapeFit",
    "TruthShape",
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
