"""Image sources (plug-ins of the ``objrec.sources`` group): ``demo[:seed=N,frames=N,truth=PATH]``, ``camera:N``, an
image file, a video file, or a folder of images."""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from objrec_core import Frame, FrameSource, Int, SourceError, SourceSpec, Str
from objrec_core.demo_source import DemoSceneSource
from objrec_core.folder_source import FolderFilesSource, PathSource, file_stamp
from strictio import IMAGE_PIXELS, InputError, open_input
from strictio.image_size import check_image_pixels, read_image_file, truncation
from strictio.limits import check

from .demo import FPS, DemoScene

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp")
VIDEO_SUFFIXES = (".avi", ".mp4", ".mkv", ".mov", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv", ".ogv", ".flv")
#: FFmpeg prints its own decoding errors on stderr unless told not to (-8: AV_LOG_QUIET); a source reports
#: a broken video in one line of its own. OpenCV reads this when it first uses FFmpeg (a capture or a video
#: writer), hence at import; a user's own setting wins.
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")


_quiet_lock = threading.Lock()
_quiet_depth = 0
_quiet_saved = 0


@contextlib.contextmanager
def _opencv_quiet() -> Iterator[None]:
    """OpenCV's own log lines off while it decodes: a refused image is reported once, by the caller."""
    global _quiet_depth, _quiet_saved
    with _quiet_lock:
        if _quiet_depth == 0:
            _quiet_saved = cv2.utils.logging.getLogLevel()
            cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
        _quiet_depth += 1
    try:
        yield
    finally:
        with _quiet_lock:
            _quiet_depth -= 1
            if _quiet_depth == 0:
                cv2.utils.logging.setLogLevel(_quiet_saved)


def decode_image(data: bytes | bytearray | memoryview, name: str, flags: int = cv2.IMREAD_COLOR,
                 where: str = "") -> np.ndarray:
    """Decode an image held in memory, after its header passed the pixel limit and its end was found.

    Every refusal is an InputError naming ``name`` (and ``where`` in it): an unknown format, a size over
    ``OBJREC_MAX_IMAGE_PIXELS``, a JPEG or PNG cut short (their decoders would return it half grey), a size
    OpenCV itself refuses, or bytes it cannot decode.
    """
    check_image_pixels(name, data, where)
    cut = truncation(data)
    if cut is not None:
        raise InputError(name, cut, where)
    try:
        with _opencv_quiet():
            image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), flags)
    except cv2.error as exc:
        raise InputError(name, f"OpenCV refuses to decode it: {_cv_reason(exc)}", where) from None
    if image is None or image.size == 0:
        raise InputError(name, "not a readable image (corrupt, or a format OpenCV cannot decode)", where)
    return image


def _cv_reason(exc: cv2.error) -> str:
    """The useful last part of an OpenCV error ("... error: (-4:Insufficient memory) Failed to ...")."""
    text = " ".join(str(exc).split())
    return text.split(" error: ", 1)[-1][:200]


def read_image(path: Path) -> np.ndarray:
    """Read a colour image through strictio: a regular file, its size checked from the header before it is
    decoded, and refused whole when it is cut short; InputError naming the file otherwise."""
    data, _size = read_image_file(path)
    return decode_image(data, str(path))


class ImageFileSource(PathSource):
    """One image, given once (or ``repeat`` times, to tune on a still picture)."""

    kind = "2d"
    extensions = IMAGE_SUFFIXES
    summary = "an image file"

    def __init__(self, path: str | Path, repeat: int = 1, name: str | None = None) -> None:
        self.path = Path(path)
        self.name = name if name is not None else str(path)
        self.repeat = repeat
        self._image = read_image(self.path)

    @property
    def length(self) -> int:
        return self.repeat

    def frames_from(self, index: int) -> Iterator[Frame]:
        stamp = file_stamp(self.path)
        for number in range(max(0, index), self.repeat):
            yield Frame(self._image, stamp, number, self.name)


class FolderSource(FolderFilesSource):
    """Every image in a folder, in natural order. A file that cannot be decoded is reported and skipped."""

    kind = "2d"
    file_suffixes = IMAGE_SUFFIXES  # not ``extensions``: one image given alone is an ImageFileSource
    what = "images"
    none_readable = "{name}: no readable image in the folder: none of its {count} {what} could be read"
    summary = "a folder of images"
    read_file = staticmethod(read_image)


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
            with _opencv_quiet():  # "can't open": said once, below
                self._capture = opener(target)
        except (cv2.error, OverflowError, ValueError) as exc:
            raise SourceError(f"{name}: cannot open: {str(exc).strip().splitlines()[-1]}") from None
        if not self._capture.isOpened():
            what = "camera" if is_camera else "video file"
            raise SourceError(f"{name}: cannot open {what}")
        count = int(self._capture.get(cv2.CAP_PROP_FRAME_COUNT)) if not is_camera else 0
        self._length = count if count > 0 else None
        self._fps = self._capture.get(cv2.CAP_PROP_FPS) or FPS
        if not is_camera:
            self._check_frame_size(self._capture.get(cv2.CAP_PROP_FRAME_WIDTH),
                                   self._capture.get(cv2.CAP_PROP_FRAME_HEIGHT), "frames")

    def _check_frame_size(self, width: float, height: float, what: str) -> None:
        """Refuse a video whose frames claim more pixels than the limit, before (more of) them are decoded."""
        try:
            w, h = int(width), int(height)
        except (OverflowError, ValueError):  # NaN or infinite from a broken container
            raise InputError(self.name, f"{what} of size {width}x{height}") from None
        if w > 0 and h > 0:
            check(self.name, IMAGE_PIXELS, w * h, f"{what} of {w}x{h}")

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
            with _opencv_quiet():
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
        """The frames from ``index`` on. A file that ends before the frame count its header claims (one frame
        short is tolerated: containers round it) is an InputError once the frames before were delivered, so
        that a command keeps what it made of them and still fails."""
        start = time.time() - index / self._fps
        first = index
        while True:
            image = self._read()
            if image is None:
                if index == 0 and not self.is_camera:
                    raise SourceError(f"{self.name}: not a video OpenCV can decode (no frame could be read)")
                if self._length is not None and index < self._length - 1:
                    read = f"{index} of {self._length} frames were read" if first == 0 else \
                        f"{index - first} frames were read from frame {first}"
                    raise InputError(self.name, f"truncated or corrupt: frame {index} of {self._length} cannot be "
                                                f"decoded; {read}")
                return
            if index == first and not self.is_camera:
                self._check_frame_size(image.shape[1], image.shape[0], "decoded frames")
            stamp = time.time() if self.is_camera else start + index / self._fps
            yield Frame(image, stamp, index, self.name)
            index += 1

    def close(self) -> None:
        self._capture.release()


def _is_text(path: Path) -> bool:
    """Whether a file starts like text (no video does): empty, or UTF-8 without NUL bytes."""
    try:
        with open_input(path, limit=None) as stream:
            head = stream.read(1024)
    except (InputError, OSError):
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
        if not path.is_file():  # a FIFO or a device: taken here, so that opening it says what it is
            return 1
        return 0 if _is_text(path) else 1

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> VideoSource:
        return cls(str(spec.path), spec.text)

    def __init__(
        self,
        path: str | Path,
        name: str | None = None,
        opener: Callable[[str | int], cv2.VideoCapture] | None = None,
    ) -> None:
        opener = opener or _open_video_file
        _check_video_file(path, name or str(path))
        super().__init__(str(path), name or str(path), is_camera=False, opener=opener)


def _open_video_file(target: str | int) -> cv2.VideoCapture:
    """A video file through FFmpeg only: OpenCV's other back-ends would read image sequences past the
    header checks, or print their own complaints on stderr."""
    return cv2.VideoCapture(target, cv2.CAP_FFMPEG)


def _check_video_file(path: str | Path, name: str) -> None:
    """A video file is opened by FFmpeg, which would block forever on a FIFO and read ``/dev/zero`` without
    end: only a regular file is handed over (a camera is ``camera:N``)."""
    try:
        open_input(path, limit=None).close()
    except InputError as exc:
        hint = " (for a camera, give camera:N)" if "character device" in exc.message else ""
        raise InputError(name, exc.message + hint) from None


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


class DemoSource(DemoSceneSource):
    """The synthetic demo scene, endless unless ``frames`` is given; frames carry ground truth.

    ``truth=PATH`` also saves that truth as a COCO JSON label file (objrec2d.truth, keyed by frame index) of
    every frame produced: when the ``frames``-th is produced and when the source is closed, atomically, so a
    run of ``objrec-detect`` or ``objrec-eval`` leaves the label file of exactly the frames it saw."""

    kind = "2d"
    summary = "demo[:seed=N,frames=N,truth=PATH], coloured shapes and a textured poster with ground truth"
    options = {  # noqa: RUF012 - declarations, never mutated
        **DemoSceneSource.options,
        "truth": Str(None, "save the truth of every frame produced to this COCO JSON file", optional=True),
    }
    FPS = FPS  # the scene's own rate (objrec2d.demo)

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> DemoSource:
        return cls(options["seed"], options["frames"] or None, name=spec.text, truth=options["truth"])

    def __init__(self, seed: int = 0, frames: int | None = None, scene: DemoScene | None = None,
                 name: str | None = None, truth: str | os.PathLike[str] | None = None) -> None:
        super().__init__(seed, frames, name)
        self.scene = scene if scene is not None else DemoScene(seed=seed)
        self.truth_path = Path(truth).expanduser() if truth is not None and str(truth) else None
        if self.truth_path is not None and not self.truth_path.parent.is_dir():
            raise SourceError(f"{self.name}: truth={truth}: folder {self.truth_path.parent} does not exist")
        self._truth: Any = None  # the TruthSet being gathered
        self._unsaved = False
        self._size: tuple[int, int] | None = None

    def render(self, index: int) -> tuple[np.ndarray, Any]:
        return self.scene.render(index)

    def __iter__(self) -> Iterator[Frame]:
        for frame in super().__iter__():
            if self.truth_path is not None:
                self._gather(frame)
            yield frame

    def _gather(self, frame: Frame) -> None:
        from objrec_core.evaluation import TruthSet

        from .truth import truth_from_demo

        if self._truth is None:
            self._truth = TruthSet("2d", [], "index", str(self.truth_path))
        self._truth.add(truth_from_demo(frame.truth, frame.index))
        self._size = (frame.data.shape[1], frame.data.shape[0])
        self._unsaved = True
        if self.frames is not None and frame.index == self.frames - 1:
            self.save_truth()

    def save_truth(self) -> None:
        """Write the truth gathered so far (``truth=PATH``), if any frame was added since the last save."""
        if self.truth_path is None or not self._unsaved:
            return
        from .truth import write_coco

        write_coco(self.truth_path, self._truth, self._size)
        self._unsaved = False
        log.info("%s: truth of %d frames saved to %s", self.name, len(self._truth), self.truth_path)

    def close(self) -> None:
        self.save_truth()
        super().close()


def open_source(spec: str) -> FrameSource:
    """Open an image source by its spec (``demo``, ``camera:0``, a file or a folder): a shortcut for
    ``objrec_core.open_source(spec, "2d")``."""
    from objrec_core import open_source as open_any

    return open_any(spec, "2d")
