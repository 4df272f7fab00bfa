"""Image sources (plug-ins of the ``objrec.sources`` group): ``demo[:seed=N,frames=N]``, ``camera:N``, an
image file, a video file, or a folder of images."""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from objrec_core import Frame, FrameSource, Int, SourceError, SourceSpec

from .demo import FPS, DemoScene

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp")
VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv", ".ogv", ".flv")


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

    kind = "2d"
    extensions = IMAGE_SUFFIXES
    summary = "an image file"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> ImageFileSource:
        assert spec.path is not None
        return cls(spec.path)

    def __init__(self, path: str | Path, repeat: int = 1) -> None:
        self.path = Path(path)
        self.name = str(path)
        self.repeat = repeat
        self._image = read_image(self.path)

    @property
    def length(self) -> int:
        return self.repeat

    @property
    def seekable(self) -> bool:
        return True

    def __iter__(self) -> Iterator[Frame]:
        return self.frames_from(0)

    def frames_from(self, index: int) -> Iterator[Frame]:
        stamp = self.path.stat().st_mtime
        for number in range(max(0, index), self.repeat):
            yield Frame(self._image, stamp, number, self.name)


class FolderSource(FrameSource):
    """Every image in a folder, in natural order. A file that cannot be decoded is reported and skipped."""

    kind = "2d"
    folders = True
    summary = "a folder of images"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> FolderSource:
        assert spec.path is not None
        return cls(spec.path)

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

    @property
    def seekable(self) -> bool:
        return True

    def __iter__(self) -> Iterator[Frame]:
        return self.frames_from(0)

    def frames_from(self, index: int) -> Iterator[Frame]:
        """From the ``index``-th image on; each frame's ``source`` is its file, so a viewer can name it."""
        start = max(0, index)
        for number, file in enumerate(self.files[start:], start):
            image = cv2.imread(str(file), cv2.IMREAD_COLOR)
            if image is None:
                log.warning("%s: not a readable image, skipped", file)
                if file not in self.skipped:
                    self.skipped.append(file)
                continue
            yield Frame(image, file.stat().st_mtime, number, str(file))
        if len(self.skipped) == len(self.files):
            raise SourceError(f"{self.name}: none of its {len(self.files)} images could be read")


class CaptureSource(FrameSource):
    """The shared base of ``VideoSource`` and ``CameraSource``: frames through ``cv2.VideoCapture``.

    A camera that drops out is retried ``retries`` times, ``retry_delay`` seconds apart, then reported;
    a file simply ends. ``opener`` makes the capture (tests pass a fake camera).
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

    @property
    def rate(self) -> float | None:
        return None if self.is_camera else self._fps

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

    @property
    def seekable(self) -> bool:
        """A video file of known length can be positioned; a camera cannot."""
        return not self.is_camera and self._length is not None

    def frames_from(self, index: int) -> Iterator[Frame]:
        """From frame ``index`` on: the capture is positioned there (FFmpeg seeks to the frame, decoding from
        the key frame before it). The capture is shared, so only the newest iterator reads correctly."""
        if not self.seekable:
            return super().frames_from(index)
        index = max(0, index)
        if self._length is not None and index >= self._length:
            return iter(())
        self._capture.set(cv2.CAP_PROP_POS_FRAMES, float(index))
        return self._frames(index)

    def __iter__(self) -> Iterator[Frame]:
        return self._frames(0)

    def _frames(self, index: int) -> Iterator[Frame]:
        start = time.time() - index / self._fps
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


def _is_text(path: Path) -> bool:
    """Whether a file starts like text (no video does): empty, or UTF-8 without NUL bytes."""
    try:
        with path.open("rb") as stream:
            head = stream.read(1024)
    except OSError:
        return False  # let opening it report the problem
    if b"\0" in head:
        return False
    try:
        head.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


class VideoSource(CaptureSource):
    """A video file through OpenCV's FFmpeg. Any other binary file no source reads by its extension is tried
    as a video too (containers come with many suffixes); a text file is not, so that a stray notes.txt gets
    "no source reads this" rather than a misleading answer."""

    kind = "2d"
    extensions = VIDEO_SUFFIXES
    summary = "a video file"

    @classmethod
    def path_score(cls, path: Path) -> int:
        if path.is_dir():
            return 0
        if path.suffix.lower() in cls.extensions:
            return 2
        return 0 if _is_text(path) else 1

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> VideoSource:
        return cls(str(spec.path), spec.text)

    def __init__(
        self,
        path: str | Path,
        name: str | None = None,
        opener: Callable[[str | int], cv2.VideoCapture] = cv2.VideoCapture,
    ) -> None:
        super().__init__(str(path), name or str(path), is_camera=False, opener=opener)


class CameraSource(CaptureSource):
    """A camera by number (``camera:0``), retried a few times when it stops delivering."""

    kind = "2d"
    schemes = ("camera",)
    options = {"index": Int(0, "the camera's number (0: the first)", min=0, max=1000)}  # noqa: RUF012
    positional = ("index",)
    summary = "camera:N, a camera by number"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> CameraSource:
        return cls(options["index"], spec.text)

    def __init__(
        self,
        index: int = 0,
        name: str | None = None,
        retries: int = 5,
        retry_delay: float = 0.2,
        opener: Callable[[str | int], cv2.VideoCapture] = cv2.VideoCapture,
    ) -> None:
        super().__init__(index, name or f"camera:{index}", is_camera=True, retries=retries, retry_delay=retry_delay,
                         opener=opener)


class DemoSource(FrameSource):
    """The synthetic demo scene, endless unless ``frames`` is given; frames carry ground truth."""

    kind = "2d"
    schemes = ("demo",)
    options = {  # noqa: RUF012 - declarations, never mutated
        "seed": Int(0, "random seed of the scene's layout and noise", min=0, max=2**31 - 1),
        "frames": Int(0, "how many frames (0: endless)", min=0),
    }
    positional = ("seed",)
    summary = "demo[:seed=N,frames=N], coloured shapes and a textured poster with ground truth"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> DemoSource:
        return cls(options["seed"], options["frames"] or None, name=spec.text)

    def __init__(self, seed: int = 0, frames: int | None = None, scene: DemoScene | None = None,
                 name: str | None = None) -> None:
        self.scene = scene if scene is not None else DemoScene(seed=seed)
        self.name = name or ("demo" if seed == 0 else f"demo:seed={seed}")
        self.frames = frames

    @property
    def length(self) -> int | None:
        return self.frames

    @property
    def rate(self) -> float:
        return float(FPS)

    def __iter__(self) -> Iterator[Frame]:
        start = time.time()
        index = 0
        while self.frames is None or index < self.frames:
            image, truth = self.scene.render(index)
            yield Frame(image, start + index / FPS, index, self.name, truth)
            index += 1


def open_source(spec: str) -> FrameSource:
    """Open an image source by its spec (``demo``, ``camera:0``, a file or a folder): a shortcut for
    ``objrec_core.open_source(spec, "2d")``."""
    from objrec_core import open_source as open_any

    return open_any(spec, "2d")
