"""Writes annotated frames: a video when the path names one, otherwise a folder of numbered PNGs.

A video is written under a temporary name and renamed at the end, or after a failure where any of its frames
can be read: a full disk never leaves a video none of whose frames plays. It goes through
``strictio.video.VideoFile``, which watches the file grow and reads the frame count back at close, since
OpenCV's writer reports no write error; a video short of frames, or a picture that cannot be written, is a
``strictio.OutputError`` saying how many frames are readable.
"""

from __future__ import annotations

import contextlib
import logging
import os
import stat
from pathlib import Path

import cv2
import numpy as np

from strictio import OutputError
from strictio.atomic import is_read_only, remove_stale_temporaries, temporary_path
from strictio.video import VIDEO_CODECS, VideoFile, readable_frames

__all__ = ["IMAGE_SUFFIXES", "PICTURE_NAMES", "VIDEO_CODECS", "AnnotationError", "AnnotationWriter", "readable_frames"]

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"}
#: The names of the pictures in a folder of them (a glob).
PICTURE_NAMES = "frame_*.png"


class AnnotationError(RuntimeError):
    """The annotation target cannot be used (a picture's name, a folder that cannot be made)."""


class AnnotationWriter:
    """Annotated frames into a video (``.avi``, ``.mp4``, ``.mkv``) or a folder of ``frame_NNNNNN.png``.

    Missing parent folders are made. Each PNG is written under a temporary name and renamed, so the folder
    holds only whole pictures; every write failure is an OutputError.
    """

    def __init__(self, path: str | Path, fps: float = 30.0) -> None:
        self.path = Path(path)
        self.fps = fps
        self.count = 0
        self._video: VideoFile | None = None
        self._failure: OutputError | None = None
        self.is_video = self.path.suffix.lower() in VIDEO_CODECS
        if self.path.suffix.lower() in IMAGE_SUFFIXES:
            raise AnnotationError(
                f"{self.path}: names one picture; give a folder (one PNG per frame) or a video (.avi, .mp4)"
            )
        self._temporary: Path | None = None
        if self.is_video:
            self._check_video_target()
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise AnnotationError(f"{self.path}: cannot create the folder {self.path.parent}: {exc}") from None
            remove_stale_temporaries(self.path.parent)
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
                self._temporary = temporary_path(self._real_path, self.path.suffix)
                self._video = VideoFile(self._temporary, self.fps, (width, height), shown_as=self.path)
            if (width, height) != self._video.size:  # a video has one frame size; keep it
                image = cv2.resize(image, self._video.size)
            video = self._video
            try:
                video.write(image)
            except OutputError as exc:
                self._video, self._failure = None, exc  # released and counted already: close has nothing to do
                self._settle(readable_frames(video.path, video.frames))
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
        if video is None:
            return
        try:
            video.close()
        except OutputError:
            self._settle(readable_frames(video.path, video.frames))
            raise
        self._settle(video.frames)

    @property
    def _real_path(self) -> Path:
        return Path(os.path.realpath(self.path))

    def _settle(self, readable: int) -> None:
        """The video, written under a temporary name, renamed to its own where any frame of it can be read;
        removed where none can."""
        temporary, self._temporary = self._temporary, None
        if temporary is None:
            return
        if readable > 0:
            try:
                os.replace(temporary, self._real_path)  # a link keeps pointing at the video it names
                return
            except OSError as exc:
                with contextlib.suppress(OSError):
                    os.unlink(temporary)
                raise OutputError(self.path, f"cannot be written: {exc.strerror or exc}") from None
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        log.debug("%s: no frame readable, nothing kept", self.path)
