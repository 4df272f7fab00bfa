"""The ``3d`` data-kind plug-in (entry point ``objrec.kinds``): how the apps open point-cloud sources and
draw the ``--annotate`` picture, without importing Open3D or OpenCV themselves."""

from __future__ import annotations

from typing import Any

import numpy as np

from objrec_core import Frame, FrameSource

from .sources import open_source as _open_source

__all__ = ["annotate", "open_source"]


def open_source(spec: str) -> FrameSource:
    """A point-cloud source from its name: ``demo``, a .pcd/.ply file, a folder, ``rgbd:...``, ``realsense``."""
    return _open_source(spec)


def annotate(frame: Frame, array: Any) -> np.ndarray:
    """The cloud seen from the sensor (BGR uint8, H x W x 3) with the detected boxes drawn."""
    from .annotate import annotate as draw

    return draw(frame, array)
