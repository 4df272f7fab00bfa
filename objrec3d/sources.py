"""Point-cloud sources (plug-ins of the ``objrec.sources`` group), named with the same grammar as every source.

- ``demo`` / ``demo:3`` / ``demo:seed=3,frames=50``: the synthetic scene (``demo.py``), with ground truth.
- ``PATH.pcd`` / ``PATH.ply``: one file; ``FOLDER``: every .pcd/.ply in it, in natural name order (one that
  cannot be read is skipped with a warning; ``objrec_core.folder_source``). Both formats are read by NumPy,
  through strictio (``pcd.py``, ``ply.py``).
- ``rgbd:COLOR,DEPTH[,INTRINSICS.json]`` (or ``rgbd:color=…,depth=…,intrinsics=…``): a colour and a depth
  image (16-bit millimetres, or set ``depth_scale`` in the JSON) back-projected into an organized cloud. The
  JSON is Open3D's ``PinholeCameraIntrinsic`` format (``width``, ``height``, column-major
  ``intrinsic_matrix``); without one the PrimeSense defaults (fx = fy = 525, centre at the image centre) are
  used.
- ``realsense`` / ``realsense:N``: an Intel RealSense camera through Open3D's sensor API.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import Frame, FrameSource, Int, SourceError, SourceSpec, Str
from objrec_core.demo_source import DemoSceneSource
from objrec_core.folder_source import FolderFilesSource
from strictio import read_text
from strictio.image_size import check_image_pixels

from .cloud import PointCloud
from .pcd import CloudFileError, read_pcd
from .ply import read_ply

log = logging.getLogger(__name__)

CLOUD_SUFFIXES = (".pcd", ".ply")
#: An intrinsics JSON is a few hundred bytes.
_MAX_INTRINSICS_BYTES = 1024 * 1024


def read_cloud(path: str | Path) -> PointCloud:
    """Read a .pcd or .ply file; CloudFileError names the file and the problem."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".pcd":
        return read_pcd(path)
    if suffix == ".ply":
        return read_ply(path)
    raise CloudFileError(path, f"unknown point-cloud format {suffix or '(no suffix)'} (.pcd or .ply)")


def _quiet(o3d: Any) -> Any:
    """Open3D's own messages off (errors only) for the duration of a call."""
    return o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error)


class FileSource(FolderFilesSource):
    """One cloud file, or every cloud file of a folder in natural name order.

    In a folder, a file that cannot be read is reported (one warning naming it and why) and skipped, as a
    folder of images does; only when none of them could be read is that an error. One file given alone that
    cannot be read is an error at once."""

    kind = "3d"
    extensions = CLOUD_SUFFIXES
    what = "point-cloud files"
    summary = "a .pcd or .ply file, or a folder of them"
    read_file = staticmethod(read_cloud)


class DemoSource(DemoSceneSource):
    """The synthetic scene, endless unless ``frames`` is given (the sphere rolls; new noise each frame).

    ``truth=PATH`` writes the truth of every frame produced to a 3D label file (``objrec3d.truth``, keyed by
    index), atomically, when the source reaches ``frames`` or is closed: the file objrec-eval and objrec-tune
    read back for the same frames (``demo:seed=S`` gives the same scene again)."""

    kind = "3d"
    options = {  # noqa: RUF012 - declarations, never mutated
        **DemoSceneSource.options,
        "truth": Str("", "write the truth of every frame produced to this 3D label file (.yaml)"),
    }
    summary = "demo[:seed=N,frames=N,truth=PATH], a table with a cylinder, a sphere and clutter, with ground truth"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> DemoSource:
        source = cls(options["seed"], options["frames"] or None, name=spec.text)
        if options["truth"]:
            folder = Path(options["truth"]).expanduser().parent
            if not folder.is_dir():
                raise SourceError(f"{spec.text}: truth={options['truth']}: folder {folder} does not exist")
            source.truth_path = Path(options["truth"]).expanduser()
        return source

    #: Where the truth of the frames produced is written (None: nowhere).
    truth_path: Path | None = None

    def render(self, index: int) -> tuple[PointCloud, Any]:
        from .demo import demo_scene

        return demo_scene(self.seed, index)

    def __iter__(self) -> Iterator[Frame]:
        if self.truth_path is None:
            yield from super().__iter__()
            return
        from objrec_core.evaluation import FrameTruth, TruthSet

        from .truth import demo_truth_shapes

        if getattr(self, "_truth", None) is None:
            self._truth = TruthSet("3d", path=str(self.truth_path))
        for frame in super().__iter__():
            self._truth.add(FrameTruth(frame.index, None, demo_truth_shapes(frame.truth)))
            self._unsaved = True
            yield frame
        self.save_truth()

    def save_truth(self) -> None:
        """Write the truth of the frames produced so far (nothing when there is nothing new)."""
        if self.truth_path is not None and getattr(self, "_unsaved", False):
            from .truth import write_truth

            write_truth(self.truth_path, self._truth)
            self._unsaved = False
            log.info("%s: the truth of %d frames written to %s", self.name, len(self._truth), self.truth_path)

    def close(self) -> None:
        self.save_truth()
        super().close()


class RGBDSource(FrameSource):
    """One colour + depth pair back-projected with pinhole intrinsics into an organized cloud."""

    kind = "3d"
    schemes = ("rgbd",)
    options = {  # noqa: RUF012 - declarations, never mutated
        "color": Str("", "the colour image"),
        "depth": Str("", "the depth image (16-bit millimetres, or float metres)"),
        "intrinsics": Str("", "Open3D's PinholeCameraIntrinsic JSON (default: fx = fy = 525, centred)"),
    }
    positional = ("color", "depth", "intrinsics")
    summary = "rgbd:COLOR,DEPTH[,INTRINSICS.json], a colour and depth image pair"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> RGBDSource:
        if not options["color"] or not options["depth"]:
            raise SourceError(f"{spec.text}: expected rgbd:COLOR,DEPTH[,INTRINSICS.json]")
        return cls(spec.text, options["color"], options["depth"], options["intrinsics"] or None)

    def __init__(self, spec: str, color: str, depth: str, intrinsics: str | None = None) -> None:
        self.name = spec
        self.color, self.depth, self.intrinsics = Path(color), Path(depth), intrinsics
        for path in (self.color, self.depth, *([Path(intrinsics)] if intrinsics else [])):
            if not path.is_file():
                raise SourceError(f"{spec}: {path} does not exist")

    @property
    def length(self) -> int:
        return 1

    def __iter__(self) -> Iterator[Frame]:
        yield Frame(self.read(), index=0, source=self.name)

    def read(self) -> PointCloud:
        import open3d as o3d

        for path in (self.depth, self.color):  # regular files, sizes checked from their headers before decoding
            check_image_pixels(path, path)
        with _quiet(o3d):
            depth = np.asarray(o3d.io.read_image(str(self.depth)))
            color = np.asarray(o3d.io.read_image(str(self.color)))
        if depth.ndim != 2 or depth.size == 0:
            raise SourceError(f"{self.name}: {self.depth} is not a single-channel depth image")
        h, w = depth.shape
        fx = fy = 525.0
        cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
        scale = 1000.0 if depth.dtype != np.float32 else 1.0
        if self.intrinsics:
            try:
                data = json.loads(read_text(self.intrinsics, _MAX_INTRINSICS_BYTES))
                k = data["intrinsic_matrix"]  # column-major, as Open3D writes it
                fx, fy, cx, cy = float(k[0]), float(k[4]), float(k[6]), float(k[7])
                scale = float(data.get("depth_scale", scale))
            except (OSError, ValueError, KeyError, IndexError, TypeError) as exc:
                raise SourceError(f"{self.name}: {self.intrinsics} is not an intrinsics JSON: {exc}") from None
        if color.shape[:2] != (h, w):
            raise SourceError(f"{self.name}: colour image {color.shape[1]}x{color.shape[0]} and depth {w}x{h} differ")
        z = depth.astype(np.float32) / np.float32(scale)
        z[z <= 0] = np.nan
        v, u = np.mgrid[0:h, 0:w].astype(np.float32)
        points = np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=-1)
        colors = color[..., :3] if color.ndim == 3 else np.repeat(color[..., None], 3, axis=2)
        return PointCloud(points, colors.astype(np.uint8) if colors.dtype != np.uint8 else colors, w, h)


class RealSenseSource(FrameSource):
    """An Intel RealSense camera through Open3D's ``t.io.RealSenseSensor``."""

    kind = "3d"
    schemes = ("realsense",)
    options = {"device": Int(0, "the camera's number among those connected", min=0, max=64)}  # noqa: RUF012
    positional = ("device",)
    summary = "realsense[:N], an Intel RealSense camera"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> RealSenseSource:
        return cls(spec.text, options["device"])

    def __init__(self, spec: str, device: int = 0) -> None:
        self.name = spec
        try:
            import open3d as o3d

            sensor_type = o3d.t.io.RealSenseSensor
        except (ImportError, AttributeError):
            raise SourceError(f"{spec}: this Open3D build has no RealSense support (open3d-cpu has none; "
                              "install the full open3d wheel on a machine with librealsense)") from None
        with _quiet(o3d):
            devices = sensor_type.list_devices() if hasattr(sensor_type, "list_devices") else []
        if not devices:
            raise SourceError(f"{spec}: no RealSense camera is connected")
        if device >= len(devices):
            raise SourceError(f"{spec}: camera {device} asked for, {len(devices)} connected")
        self.sensor = sensor_type()
        self.sensor.init_sensor(o3d.t.io.RealSenseSensorConfig(), device, "")
        self.sensor.start_capture(False)

    def __iter__(self) -> Iterator[Frame]:
        index = 0
        metadata = self.sensor.get_metadata()
        k = np.asarray(metadata.intrinsics.intrinsic_matrix)
        fx, fy, cx, cy = k[0, 0], k[1, 1], k[0, 2], k[1, 2]
        scale = float(metadata.depth_scale)
        while True:
            image = self.sensor.capture_frame(True, True)
            depth = np.asarray(image.depth.cpu()).astype(np.float32)[..., 0] / scale
            color = np.asarray(image.color.cpu())
            depth[depth <= 0] = np.nan
            h, w = depth.shape
            v, u = np.mgrid[0:h, 0:w].astype(np.float32)
            points = np.stack([(u - cx) * depth / fx, (v - cy) * depth / fy, depth], axis=-1)
            yield Frame(PointCloud(points, color[..., :3], w, h), index=index, source=self.name)
            index += 1

    def close(self) -> None:
        self.sensor.stop_capture()


def open_source(spec: str) -> FrameSource:
    """Open a point-cloud source by its spec: a shortcut for ``objrec_core.open_source(spec, "3d")``."""
    from objrec_core import open_source as open_any

    return open_any(spec, "3d")
