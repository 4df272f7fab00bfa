"""Live ROS 2 topics over DDS (cyclonedds, the ``ros2`` extra): see :mod:`.transport`.

Importing this package does not import cyclonedds; opening a transport does (or says which extra to install).
"""

from __future__ import annotations

from .transport import NEEDS_EXTRA, Ros2Transport

__all__ = ["NEEDS_EXTRA", "Ros2Transport"]
