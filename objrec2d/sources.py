"""Image sources, chosen by one string: ``camera:N``, a video file, an image file, a folder, or ``demo``."""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np

from objrec_core import Frame, FrameSource, SourceError

from .demo import FPS, DemoScene

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp"}
CLOUD_SUFFIXES = {".pcd", ".ply", ".xyz", ".pts"}


def _natural_key(path: Path) -> list[object]:
    """frame2.png before frame10.png."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def read_image(path: Path) -> np.ndarray:
    """Read a colour image, with a clear error where it is missing or not an image."""
    if not path.is_file():
        raise SourceError(f"{path}: no such image file")
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise SourceError(f"{path}: not a readable image (corrupt, or a format OpenCV cannot decode)")
    return image


class ImageFileSource(FrameSource):
    """One image, given once (or ``repeat`` times, to tune on a still picture)."""

    def __init__(self, path: str | Path, repeat: int = 1) -> None:
        self.path = Path(path)
        self.name = str(path)
        self.repeat = repeat
        self._image = read_image(self.path)

    @property
    def length(self) -> int:
        return self.repeat

    def __iter__(self) -> Iterator[Frame]:
        stamp = self.path.stat().st_mtime
        for index in range(self.repeat):
            yield Frame(self._image, stamp, index, self.name)


class FolderSource(FrameSource):
    """Every image in a folder, in natural order. A file that cannot be decoded is reported and skipped."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.name = str(path)
        try:
            entries = list(self.path.iterdir())
        except OSError as exc:
            raise SourceError(f"{path}: cannot list the folder: {exc.strerror or exc}") from None
        self.files = sorted(
            (p for p in entries if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file()), key=_natural_key
        )
        if not self.files:
            raise SourceError(f"{path}: folder holds no images ({', '.join(sorted(IMAGE_SUFFIXES))})")
        self.skipped: list[Path] = []

    @property
    def length(self) -> int:
        return len(self.files)

    def __iter__(self) -> Iterator[Frame]:
        for index, file in enumerate(self.files):
            image = cv2.imread(str(file), cv2.IMREAD_COLOR)
            if image is None:
                log.warning("%s: not a readable image, skipped", file)
                self.skipped.append(file)
                continue
            yield Frame(image, file.stat().st_mtime, index, str(file))
        if len(self.skipped) == len(self.files):
            raise SourceError(f"{self.name}: none of its {len(self.files)} images could be read")


class CaptureSource(FrameSource):
    """A video file or camera through ``cv2.VideoCapture``.

    A camera that drops out is retried ``retries`` times, ``retry_delay`` seconds apart, then reported;
    a file simply ends.
    """

    def __init__(
        self,
        target: str | int,
        name: str,
        is_camera: bool,
        retries: int = 5,
        retry_delay: float = 0.2,
        opener: Callable[[str | int], cv2.VideoCapture] = cv2.VideoCapture,
    ) -> None:
        self.name = name
        self.is_camera = is_camera
        self.retries = retries
        self.retry_delay = retry_delay
        self._target = target
        self._opener = opener
        try:
            self._capture = opener(target)
        except (cv2.error, OverflowError, ValueError) as exc:
            raise SourceError(f"{name}: cannot open: {str(exc).strip().splitlines()[-1]}") from None
        if not self._capture.isOpened():
            what = "camera" if is_camera else "video file"
            raise SourceError(f"{name}: cannot open {what}")
        count = int(self._capture.get(cv2.CAP_PROP_FRAME_COUNT)) if not is_camera else 0
        self._length = count if count > 0 else None
        self._fps = self._capture.get(cv2.CAP_PROP_FPS) or FPS

    @property
    def length(self) -> int | None:
        return self._length

    def _read(self) -> np.ndarray | None:
        ok, image = self._capture.read()
        if ok and image is not None:
            return image
        if not self.is_camera:
            return None
        for attempt in range(1, self.retries + 1):
            log.warning("%s: no frame, retrying (%d/%d)", self.name, attempt, self.retries)
            time.sleep(self.retry_delay)
            self._capture.release()
            self._capture = self._opener(self._target)
            ok, image = self._capture.read() if self._capture.isOpened() else (False, None)
            if ok and image is not None:
                return image
        raise SourceError(f"{self.name}: camera stopped delivering frames after {self.retries} retries")

    def __iter__(self) -> Iterator[Frame]:
        start = time.time()
        index = 0
        while True:
            image = self._read()
            if image is None:
                if index == 0 and not self.is_camera:
                    raise SourceError(f"{self.name}: not a video OpenCV can decode (no frame could be read)")
                if self._length is not None and index < self._length - 1:
                    raise SourceError(
                        f"{self.name}: frame {index} of {self._length} cannot be decoded (truncated or corrupt)"
                    )
                return
            stamp = time.time() if self.is_camera else start + index / self._fps
            yield Frame(image, stamp, index, self.name)
            index += 1

    def close(self) -> None:
        self._capture.release()


class DemoSource(FrameSource):
    """The synthetic demo scene, endless unless ``frames`` is given; frames carry ground truth."""

    def __init__(self, seed: int = 0, frames: int | None = None, scene: DemoScene | None = None) -> None:
        self.scene = scene if scene is not None else DemoScene(seed=seed)
        self.name = "demo" if seed == 0 else f"demo:{seed}"
        self.frames = frames

    @property
    def length(self) -> int | None:
        return self.frames

    def __iter__(self) -> Iterator[Frame]:
        start = time.time()
        index = 0
        while self.frames is None or index < self.frames:
            image, truth = self.scene.render(index)
            yield Frame(image, start + index / FPS, index, self.name, truth)
            index += 1


def open_source(spec: str) -> FrameSource:
    """Open the source a user named: ``demo``, ``demo:SEED``, ``camera:N``, an image, a video or a folder."""
    spec = spec.strip()
    if not spec:
        raise SourceError("no source given (sources: demo, camera:N, an image, a video, a folder)")
    if spec == "demo" or spec.startswith("demo:"):
        seed_text = spec[5:] or "0"
        if not seed_text.isdigit():
            raise SourceError(f"{spec}: the demo's seed must be a whole number, as in demo:3")
        return DemoSource(seed=int(seed_text))
    if spec.startswith("camera:"):
        index_text = spec[7:]
        if not index_text.isdigit():
            raise SourceError(f"{spec}: expected camera:N with N the camera's number, as in camera:0")
        return CaptureSource(int(index_text), spec, is_camera=True)
    path = Path(spec).expanduser()
    if path.is_dir():
        return FolderSource(path)
    if not path.exists():
        raise SourceError(f"{spec}: no such file or folder (sources: demo, camera:N, an image, a video, a folder)")
    if path.suffix.lower() in IMAGE_SUFFIXES:
        return ImageFileSource(path)
    if path.suffix.lower() in CLOUD_SUFFIXES:
        raise SourceError(f"{spec}: a point cloud; it needs a 3d parameter file (this one is 2d)")
    return CaptureSource(str(path), spec, is_camera=False)
