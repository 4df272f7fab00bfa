"""A video written through OpenCV and verified, since OpenCV's writer reports no write error.

On a full disk ``cv2.VideoWriter`` goes on taking frames and leaves a file of which few are readable. A
:class:`VideoFile` therefore watches the file grow while it is written (for intra-frame codecs, where every
frame adds bytes) and, when finished, reads the frame count back (:func:`readable_frames`). The navigation
stack's animations and the apps' annotated videos both write through it; OpenCV is imported only when a video
is written, so strictio stays light for everything else.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import OutputError

if TYPE_CHECKING:
    import numpy as np

#: The codec each video container is written with.
VIDEO_CODECS = {".avi": "MJPG", ".mp4": "mp4v", ".mkv": "MJPG", ".mov": "mp4v"}
#: Codecs that encode every frame whole, so that the file must grow with the frames.
INTRA_CODECS = {"MJPG"}
#: Bytes a video writer may hold before the file grows (FFmpeg's buffer is 256 KiB); twice this much encoded
#: without growth means the bytes are not reaching the file.
_WRITE_BUFFER = 1024 * 1024
#: Frames without growth that mean a failure before any growth was seen (a frame takes >= 200 bytes).
_FIRST_GROWTH_FRAMES = 2 * _WRITE_BUFFER // 200


def _cv2() -> Any:
    import cv2

    return cv2


@contextlib.contextmanager
def quiet_video_warnings() -> Iterator[None]:
    """OpenCV's FFmpeg writer warns on stderr at every frame it cannot write; the failure is reported once,
    as an OutputError, instead."""
    cv_log = _cv2().utils.logging
    level = cv_log.getLogLevel()
    cv_log.setLogLevel(min(level, cv_log.LOG_LEVEL_ERROR))
    try:
        yield
    finally:
        cv_log.setLogLevel(level)


@contextlib.contextmanager
def _stderr_silenced() -> Iterator[None]:
    """Reading back a video that may be cut short makes FFmpeg print its complaints straight to file
    descriptor 2; what matters is the count, reported in one line by the caller."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def readable_frames(path: str | os.PathLike[str], expected: int) -> int:
    """How many frames of the video at ``path`` can be read, counting no further than ``expected``.

    The container's count is trusted when it agrees; otherwise the frames are grabbed one by one.
    """
    with _stderr_silenced():
        return _count_frames(Path(path), expected)


def _count_frames(path: Path, expected: int) -> int:
    cv2 = _cv2()
    capture = cv2.VideoCapture(str(path))
    try:
        if not capture.isOpened():
            return 0
        if capture.get(cv2.CAP_PROP_FRAME_COUNT) == expected:
            return expected
        count = 0
        while count < expected and capture.grab():
            count += 1
        return count
    finally:
        capture.release()


class VideoFile:
    """One video being written (its codec chosen by the suffix of ``path``), checked when finished.

    ``shown_as`` is the path errors name (the final name when ``path`` is a temporary one). With
    ``watch_growth`` an intra-frame video that stops growing is an OutputError at once, so that a long run on a
    full disk stops early rather than after every frame went nowhere.
    """

    def __init__(self, path: str | os.PathLike[str], fps: float, size: tuple[int, int], *,
                 shown_as: str | os.PathLike[str] | None = None, watch_growth: bool = True) -> None:
        cv2 = _cv2()
        self.path = Path(path)
        self.shown_as = Path(shown_as) if shown_as is not None else self.path
        self.size = size
        self.codec = VIDEO_CODECS[self.path.suffix.lower()]
        self.frames = 0
        self._watch = watch_growth and self.codec in INTRA_CODECS
        self._grown = (0, 0)  # (frames, bytes) when the file last grew
        with quiet_video_warnings():
            self._writer = cv2.VideoWriter(str(self.path), cv2.VideoWriter_fourcc(*self.codec), fps, size)
        if not self._writer.isOpened():
            raise OutputError(self.shown_as, "cannot be written: OpenCV cannot write this video format here")

    def write(self, image: np.ndarray) -> None:
        """Add one frame (of :attr:`size`); OutputError when the file stopped growing."""
        with quiet_video_warnings():
            self._writer.write(image)
        self.frames += 1
        if self._watch and self._stopped_growing():
            readable = self.finish()
            raise OutputError(self.shown_as, f"cannot be written: the file stopped growing (a full disk or a file "
                                             f"size limit); {readable} of {self.frames} frames are readable")

    def _stopped_growing(self) -> bool:
        try:
            size = os.stat(self.path).st_size
        except OSError:
            return True  # removed while being written
        grown_frames, grown_bytes = self._grown
        if size > grown_bytes:
            self._grown = (self.frames, size)
            return False
        waited = self.frames - grown_frames
        if not grown_frames:
            return waited > _FIRST_GROWTH_FRAMES
        return waited > max(16, 2 * _WRITE_BUFFER * grown_frames // max(grown_bytes, 1))

    def finish(self) -> int:
        """Release the writer and return how many of the frames written read back."""
        with quiet_video_warnings():
            self._writer.release()
        return readable_frames(self.path, self.frames)

    def close(self) -> None:
        """Finish; OutputError if fewer frames than were written can be read back."""
        readable = self.finish()
        if readable < self.frames:
            raise OutputError(self.shown_as, f"cannot be written completely (a full disk or a file size limit?): "
                                             f"{readable} of {self.frames} frames are readable")
