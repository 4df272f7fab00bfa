"""What the inspection patrol needs of a data kind: frames made from an RGB-D camera's images.

This is the app's need, not the framework's: a ``Kind`` says how to check, preview and annotate its frames,
and a kind that can also be fed by a camera implements ``TakesRGBD`` besides (structurally: it defines
``from_rgbd``, with no import of this app). The ``detect`` task asks ``camera_frames(kind)`` and refuses a
parameter file whose kind does not, saying so.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class TakesRGBD(Protocol):
    """A data kind whose frames can be made from one RGB-D camera frame (``2d``: the colour image; ``3d``: an
    organized point cloud).

    ``color`` is H x W x 3 ``uint8`` BGR, ``depth`` H x W ``float32`` metres along the optical axis (NaN where
    the sensor had no return), registered to the colour image; ``fx, fy, cx, cy`` are the pinhole intrinsics
    in pixels. The result is one frame of the kind.
    """

    def from_rgbd(self, color: Any, depth: Any, fx: float, fy: float, cx: float, cy: float) -> Any: ...


class NoCameraFrames(TypeError):
    """A kind the inspection patrol cannot feed: it does not implement ``TakesRGBD``. ``kind`` is its name,
    ``why`` what it lacks."""

    def __init__(self, kind: str, why: str) -> None:
        super().__init__(f"kind {kind!r} cannot take camera frames: {why}")
        self.kind = kind
        self.why = why


def camera_frames(kind: Any) -> TakesRGBD:
    """``kind`` as a ``TakesRGBD``; NoCameraFrames naming the kind when it does not take camera frames."""
    if isinstance(kind, TakesRGBD) and callable(getattr(kind, "from_rgbd", None)):
        return kind
    raise NoCameraFrames(str(getattr(kind, "name", type(kind).__name__)),
                         f"its {type(kind).__name__} has no from_rgbd(color, depth, fx, fy, cx, cy), so it is "
                         "no objrec_apps.inspection.TakesRGBD")
