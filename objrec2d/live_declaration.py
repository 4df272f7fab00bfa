"""The ``2d.live`` source as the registry sees it before a topic is opened: its schemes, not its implementation.

:mod:`objrec2d.live_source` imports ``objrec_ros.live`` (and rosbags, and a transport when a spec names one);
a 2D run over a file, a camera or the demo scene must not. The registry reads this declaration to parse
``ros1:`` and ``ros2:`` specs and imports the implementation only when a spec names a live topic.
"""

from objrec_core.source_declaration import DeclaredSource

IMAGE_LIVE = DeclaredSource(
    kind="2d",
    implementation="objrec2d.live_source:ImageLiveSource",
    schemes=("ros1", "ros2"),
    summary=("ros1:/TOPIC[,master=URI,timeout=S] | ros2:/TOPIC[,domain=N,timeout=S]: images of a live topic "
             "(sensor_msgs/Image or CompressedImage)"),
)
