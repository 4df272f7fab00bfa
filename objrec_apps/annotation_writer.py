"""Writes annotated frames: a video when the path names one, otherwise a folder of numbered PNGs."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

VIDEO_CODECS = {".avi": "MJPG", ".mp4": "mp4v", ".mkv": "MJPG", ".mov": "mp4v"}
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"}


class AnnotationError(RuntimeError):
    """The annotation target cannot be written."""


class AnnotationWriter:
    def __init__(self, path: str | Path, fps: float = 30.0) -> None:
        self.path = Path(path)
        self.fps = fps
        self.count = 0
        self._video: cv2.VideoWriter | None = None
        self._size: tuple[int, int] | None = None
        self.is_video = self.path.suffix.lower() in VIDEO_CODECS
        if self.path.suffix.lower() in IMAGE_SUFFIXES:
            raise AnnotationError(
                f"{self.path}: names one picture; give a folder (one PNG per frame) or a video (.avi, .mp4)"
            )
        if self.is_video:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise AnnotationError(f"{self.path}: cannot create the folder {self.path.parent}: {exc}") from None
        else:
            try:
                self.path.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise AnnotationError(f"{self.path}: cannot create the folder: {exc}") from None

    def write(self, image: np.ndarray) -> None:
        if self.is_video:
            height, width = image.shape[:2]
            if self._video is None:
                fourcc = cv2.VideoWriter_fourcc(*VIDEO_CODECS[self.path.suffix.lower()])
                self._video = cv2.VideoWriter(str(self.path), fourcc, self.fps, (width, height))
                if not self._video.isOpened():
                    raise AnnotationError(f"{self.path}: OpenCV cannot write this video format here")
                self._size = (width, height)
            if (width, height) != self._size:  # a video has one frame size; keep it
                image = cv2.resize(image, self._size)
            self._video.write(image)
        else:
            target = self.path / f"frame_{self.count:06d}.png"
            if not cv2.imwrite(str(target), image):
                raise AnnotationError(f"{target}: cannot be written")
        self.count += 1

    def close(self) -> None:
        if self._video is not None:
            self._video.release()
            self._video = None
