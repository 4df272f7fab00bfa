"""Camera frames are the inspection app's need, not the framework's: a kind takes them by implementing the
app's ``TakesRGBD`` protocol (defining ``from_rgbd``), and the app says which kind does not."""

from __future__ import annotations

import numpy as np
import pytest

from objrec_apps.inspection import NoCameraFrames, TakesRGBD, camera_frames
from objrec_core import Kind, get_kind


class Bare(Kind):
    name, title = "bare", "bare things"

    def check_frame(self, data: object) -> None:
        pass

    def preview(self, data: object) -> object:
        return data

    def annotate(self, frame: object, objects: object) -> object:
        return frame


def test_the_kind_contract_has_no_camera_frames():
    assert not hasattr(Kind, "from_rgbd")
    assert not isinstance(Bare(), TakesRGBD)
    with pytest.raises(NoCameraFrames, match=r"^kind 'bare' cannot take camera frames: its Bare has no from_rgbd"):
        camera_frames(Bare())


@pytest.mark.parametrize("name", ["2d", "3d"])
def test_the_built_in_kinds_take_camera_frames(name):
    if name == "3d":
        pytest.importorskip("open3d")
    kind = get_kind(name)
    assert isinstance(kind, TakesRGBD) and camera_frames(kind) is kind
    color = np.zeros((3, 4, 3), np.uint8)
    frame = camera_frames(kind).from_rgbd(color, np.full((3, 4), 2.0, np.float32), 100.0, 100.0, 1.5, 1.0)
    assert kind.is_frame(frame)
