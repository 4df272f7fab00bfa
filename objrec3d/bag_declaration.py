"""The ``3d.bag`` source as the registry sees it before a bag is opened: its forms, not its implementation.

:mod:`objrec3d.bag_source` imports ``objrec_ros`` (and through it rosbags); the registry reads this
declaration to parse ``bag:`` specs and recognise ``.bag``/``.mcap`` files and ROS 2 bag folders, and imports
the implementation only when a spec names a bag (checking it declares the same forms).
"""

from objrec_core.source_declaration import DeclaredSource

CLOUD_BAG = DeclaredSource(
    kind="3d",
    implementation="objrec3d.bag_source:CloudBagSource",
    schemes=("bag",),
    extensions=(".bag", ".mcap"),
    folder_marker="metadata.yaml",
    summary=("bag:PATH[,topic=NAME,info_topic=NAME,color_topic=NAME,start=S,end=S,rate=R] (or a .bag/.mcap "
             "file or ROS 2 bag folder): PointCloud2 or depth images"),
)
