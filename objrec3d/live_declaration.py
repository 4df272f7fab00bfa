"""The ``3d.live`` source as the registry sees it before a topic is opened: its schemes, not its implementation.

:mod:`objrec3d.live_source` imports ``objrec_ros.live`` (and rosbags, and a transport when a spec names one);
the registry reads this declaration to parse ``ros1:`` and ``ros2:`` specs and imports the implementation
only when a spec names a live topic.
"""

from objrec_core.source_declaration import DeclaredSource

CLOUD_LIVE = DeclaredSource(
    kind="3d",
    implementation="objrec3d.live_source:CloudLiveSource",
    schemes=("ros1", "ros2"),
    summary=("ros1:/TOPIC[,info=TOPIC,color=TOPIC,master=URI,timeout=S] | ros2:/TOPIC[,info=...,domain=N]: "
             "point clouds of a live topic (PointCloud2, or a depth Image with its CameraInfo)"),
)
