"""Writes annotated frames: a video when the path names one, otherwise a folder of numbered PNGs.

OpenCV's video writer reports no write error: on a full disk it goes on taking frames and leaves a file of
which few are readable. So the writer watches the file grow while it runs (for intra-frame codecs, where
every frame adds bytes), and at close reads the frame count back; a video short of frames, or a picture
that cannot be written, is a ``strictio.OutputError`` saying how many frames are readable.
"""

from __future__ import annotations

import contextlib
import logging
import os
import stat
import sys
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from strictio import OutputError
from strictio.atomic import is_read_only, remove_stale_temporaries, temporary_path

log = logging.getLogger(__name__)

VIDEO_CODECS = {".avi": "MJPG", ".mp4": "mp4v", ".mkv": "MJPG", ".mov": "mp4v"}
#: Codecs that encode every frame whole, so that the file must grow with the frames.
INTRA_CODECS = {"MJPG"}
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"}
#: Bytes a video writer may hold before the file grows (FFmpeg's buffer is 256 KiB); twice this much encoded
#: without growth means the bytes are not reaching the file.
_WRITE_BUFFER = 1024 * 1024
#: Frames without growth that mean a failure before any growth was seen (a frame takes >= 200 bytes).
_FIRST_GROWTH_FRAMES = 2 * _WRITE_BUFFER // 200


@contextlib.contextmanager
def _quiet_video_warnings() -> Iterator[None]:
    """OpenCV's FFmpeg writer warns on stderr at every frame it cannot write; the writer reports that once,
    as an OutputError, instead."""
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(min(level, cv2.utils.logging.LOG_LEVEL_ERROR))
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(level)


class AnnotationError(RuntimeError):
    """The annotation target cannot be used (a picture's name, a folder that cannot be made)."""


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


def readable_frames(path: Path, expected: int) -> int:
    """How many frames of the video at ``path`` can be read, counting no further than ``expected``.

    The container's count is trusted when it agrees; otherwise the frames are grabbed one by one.
    """
    with _stderr_silenced():
        return _count_frames(path, expected)


def _count_frames(path: Path, expected: int) -> int:
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


class _VideoFile:
    """One video being written, watched for growth, checked at close."""

    def __init__(self, path: Path, fps: float, size: tuple[int, int]) -> None:
        self.path = path
        self.size = size
        self.codec = VIDEO_CODECS[path.suffix.lower()]
        self.frames = 0
        self._grown = (0, 0)  # (frames, bytes) when the file last grew
        self._writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*self.codec), fps, size)
        if not self._writer.isOpened():
            raise OutputError(path, "cannot be written: OpenCV cannot write this video format here")

    def write(self, image: np.ndarray) -> None:
        with _quiet_video_warnings():
            self._writer.write(image)
        self.frames += 1
        if self.codec in INTRA_CODECS and self._stopped_growing():
            with _quiet_video_warnings():
                self._writer.release()
            readable = readable_frames(self.path, self.frames)
            raise OutputError(self.path, f"cannot be written: the file stopped growing (a full disk or a file "
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

    def close(self) -> None:
        with _quiet_video_warnings():
            self._writer.release()
        readable = readable_frames(self.path, self.frames)
        if readable < self.frames:
            raise OutputError(self.path, f"cannot be written completely (a full disk or a file size limit?): "
                                         f"{readable} of {self.frames} frames are readable")


class AnnotationWriter:
    """Annotated frames into a video (``.avi``, ``.mp4``, ``.mkv``) or a folder of ``frame_NNNNNN.png``.

    Missing parent folders are made. Each PNG is written under a temporary name and renamed, so the folder
    holds only whole pictures; every write failure is an OutputError.
    """

    def __init__(self, path: str | Path, fps: float = 30.0) -> None:
        self.path = Path(path)
        self.fps = fps
        self.count = 0
        self._video: _VideoFile | None = None
        self._failure: OutputError | None = None
        self.is_video = self.path.suffix.lower() in VIDEO_CODECS
        if self.path.suffix.lower() in IMAGE_SUFFIXES:
            raise AnnotationError(
                f"{self.path}: names one picture; give a folder (one PNG per frame) or a video (.avi, .mp4)"
            )
        if self.is_video:
            self._check_video_target()
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise AnnotationError(f"{self.path}: cannot create the folder {self.path.parent}: {exc}") from None
        else:
            try:
                self.path.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise AnnotationError(f"{self.path}: cannot create the folder: {exc}") from None
            remove_stale_temporaries(self.path)

    def _check_video_target(self) -> None:
        """Refuse to write a video over a device, a FIFO, a folder or a read-only file."""
        try:
            info = self.path.stat()
        except OSError:
            return
        if not stat.S_ISREG(info.st_mode):
            raise OutputError(self.path, "cannot be written: it exists and is not a regular file")
        if is_read_only(self.path, info):
            raise OutputError(self.path, "cannot be written: the file is read-only")

    def write(self, image: np.ndarray) -> None:
        """Add one frame; OutputError when it cannot be written (earlier frames stay whole)."""
        if self._failure is not None:
            raise self._failure
        if self.is_video:
            height, width = image.shape[:2]
            if self._video is None:
                self._video = _VideoFile(self.path, self.fps, (width, height))
            if (width, height) != self._video.size:  # a video has one frame size; keep it
                image = cv2.resize(image, self._video.size)
            try:
                self._video.write(image)
            except OutputError as exc:
                self._video, self._failure = None, exc  # released and counted already: close has nothing to do
                raise
        else:
            self._write_picture(self.path / f"frame_{self.count:06d}.png", image)
        self.count += 1

    def _write_picture(self, target: Path, image: np.ndarray) -> None:
        ok, encoded = cv2.imencode(".png", image)
        if not ok:
            raise OutputError(target, "cannot be written: OpenCV cannot encode this frame as PNG")
        temporary = temporary_path(target)
        try:
            with open(temporary, "wb") as stream:
                stream.write(encoded.tobytes())
            os.replace(temporary, target)
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
            before = "the frame before it is" if self.count == 1 else f"the {self.count} frames before it are"
            raise OutputError(target, f"cannot be written: {exc.strerror or exc}; {before} whole") from None

    def close(self) -> None:
        """Finish the video and check it: OutputError if fewer frames than were given can be read back."""
        video, self._video = self._video, None
        if video is not None:
            video.close()
