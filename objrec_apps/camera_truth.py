"""The simulated RGB-D camera's own ground truth as a 3D label file (``truth=PATH`` of the commands that take
frames from it).

The camera knows what it drew (:meth:`navigation.camera.RGBDFrame.truth`: the objects in view, in the
optical frame, with their visible points), as plain data in the layout of the point-cloud kind's truth shapes.
This module, on the apps' side of the layers, gathers the frames a command takes into a
:class:`~objrec_core.evaluation.TruthSet` of the ``3d`` kind and has the kind write it (through the registry:
the apps never import a kind), so ``objrec-eval`` scores a 3D system on those frames as on any labelled
recording. Frames are numbered in the order they were taken and carry the simulated time as their stamp.
"""

from __future__ import annotations

import os
from typing import Any

from navigation.camera import RGBDFrame
from objrec_core import get_kind
from objrec_core.evaluation import FrameTruth, TruthSet

#: The kind whose label file the camera's truth is written as (its truth objects read these dicts).
TRUTH_KIND = "3d"


def camera_frame_truth(frame: RGBDFrame, index: int, obstacles: bool = False) -> FrameTruth:
    """One frame's truth: its objects as the 3D label file's plain objects; stamp: the simulated time (ns)."""
    objects: tuple[Any, ...] = tuple(s.as_dict() for s in frame.truth(obstacles))
    return FrameTruth(index, round(frame.t * 1e9), objects)


class CameraTruth:
    """The truth of every frame a command takes, in order; :meth:`write` saves it as the 3D label file."""

    def __init__(self, obstacles: bool = False) -> None:
        self.obstacles = obstacles
        self.truth = TruthSet(TRUTH_KIND, [], "index")

    def __len__(self) -> int:
        return len(self.truth)

    def add(self, frame: RGBDFrame) -> FrameTruth:
        """Keep the truth of the next frame taken (its index is the number of frames before it)."""
        label = camera_frame_truth(frame, len(self.truth), self.obstacles)
        self.truth.add(label)
        return label

    def write(self, path: str | os.PathLike[str]) -> None:
        """Save the label file atomically (an ``OutputError`` naming ``path`` when it cannot be written)."""
        get_kind(TRUTH_KIND).write_truth(path, self.truth)
