"""Images from a live ROS 1 or ROS 2 topic (plug-in ``2d.live``): ``sensor_msgs/Image`` and ``CompressedImage``.

``ros1:/camera/rgb/image_raw[,master=http://HOST:11311][,timeout=S]`` or ``ros2:/camera/color/image_raw
[,domain=N][,timeout=S]``; see :mod:`objrec_ros.live.source` for what opening waits for, the newest-wins loop
and the counts. Messages are decoded as the bag source decodes them (:func:`objrec2d.bag_source.decode_picture`:
every Image encoding it reads, jpeg and png CompressedImage), so a live frame equals the recorded one. A depth
image topic (16UC1, 32FC1) is 3D data and refused here, as the bag source leaves it out.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from objrec_ros.decode import COMPRESSED_IMAGE, IMAGE, encoding_of, is_depth_encoding
from objrec_ros.live.source import Deadline, LiveSource

from .bag_source import decode_picture
from .live_declaration import IMAGE_LIVE


class ImageLiveSource(LiveSource):
    """The images of one live topic."""

    kind = "2d"
    summary = IMAGE_LIVE.summary
    readable = (IMAGE, COMPRESSED_IMAGE)
    readable_text = "images (sensor_msgs/Image or CompressedImage)"

    def prepare(self, first: Any, deadline: Deadline) -> None:
        if self.msgtype == IMAGE and is_depth_encoding(encoding_of(first)):
            raise self.error(f"{self.topic} holds depth images ({first.encoding}), which are 3D data: run a 3d "
                             "parameter file on it (with info=<its CameraInfo topic>)")

    def decode(self, message: Any) -> np.ndarray:
        return decode_picture(self.msgtype, message)
