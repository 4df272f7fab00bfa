"""The ``2d.bag`` source as the registry sees it before a bag is opened: its forms, not its implementation.

:mod:`objrec2d.bag_source` imports ``objrec_ros`` (and through it rosbags); a 2D run over a camera or the
demo scene must not. The registry reads this declaration to parse ``bag:`` specs and to recognise ``.bag``
and ``.mcap`` files and ROS 2 bag folders, and imports the implementation only when a spec names a bag
(it then checks the implementation declares the same forms).
"""

from objrec_core.source_declaration import DeclaredSource

IMAGE_BAG = DeclaredSource(
    kind="2d",
    implementation="objrec2d.bag_source:ImageBagSource",
    schemes=("bag",),
    extensions=(".bag", ".mcap"),
    folder_marker="metadata.yaml",
    summary="bag:PATH[,topic=NAME,start=S,end=S,rate=R] (or a .bag/.mcap file or ROS 2 bag folder): images",
)
