"""Point-cloud sources (plug-ins of the ``objrec.sources`` group), named with the same grammar as every source.

- ``demo`` / ``demo:3`` / ``demo:seed=3,frames=50``: the synthetic scene (``demo.py``), with ground truth.
- ``PATH.pcd`` / ``PATH.ply``: one file; ``FOLDER``: every .pcd/.ply in it, in name order.
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
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import Frame, FrameSource, Int, SourceError, SourceSpec, Str

from .cloud import PointCloud
from .pcd import CloudFileError, read_pcd

log = logging.getLogger(__name__)

CLOUD_SUFFIXES = (".pcd", ".ply")


def read_cloud(path: str | Path) -> PointCloud:
    """Read a .pcd or .ply file; CloudFileError names the file and the problem."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".pcd":
        return read_pcd(path)
    if suffix == ".ply":
        return read_ply(path)
    raise CloudFileError(path, f"unknown point-cloud format {suffix or '(no suffix)'} (.pcd or .ply)")


def read_ply(path: str | Path) -> PointCloud:
    """Read a PLY file through Open3D, after checking its header ourselves: Open3D answers a broken file
    with an empty cloud and a warning, which would pass for a file without points."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            head = stream.read(4096)
    except FileNotFoundError:
        raise CloudFileError(path, "file not found") from None
    except OSError as exc:
        raise CloudFileError(path, f"cannot be read: {exc.strerror or exc}") from None
    if not head.startswith(b"ply"):
        raise CloudFileError(path, "not a PLY file (it does not start with 'ply')")
    end = head.find(b"end_header")
    if end < 0:
        raise CloudFileError(path, "corrupt PLY header: no end_header")
    vertices, fmt, row, element = None, "", 0, ""
    sizes = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
             "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
    for line in head[:end].decode("ascii", "replace").splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0] == "format":
            fmt = parts[1]
        elif len(parts) == 3 and parts[0] == "element":
            element = parts[1]
            if element == "vertex":
                try:
                    vertices = int(parts[2])
                except ValueError:
                    raise CloudFileError(path, f"corrupt PLY header: vertex count {parts[2]!r}") from None
        elif len(parts) == 3 and parts[0] == "property" and element == "vertex":
            row += sizes.get(parts[1], 0)
    if not vertices:
        return PointCloud.empty()  # a valid file without points: an empty cloud, an empty detection
    body_start = head.index(b"\n", end) + 1
    size = path.stat().st_size
    if fmt.startswith("binary") and size - body_start < vertices * row:
        raise CloudFileError(path, f"truncated: {size - body_start} bytes of vertex data, {vertices} points need "
                                   f"{vertices * row}")
    if fmt == "ascii":
        with path.open("rb") as stream:
            stream.seek(body_start)
            lines = sum(1 for line in stream if line.strip())
        if lines < vertices:
            raise CloudFileError(path, f"truncated: {lines} of {vertices} points present")
    import open3d as o3d

    with _quiet(o3d):  # Open3D prints its warnings on stdout, where objrec-detect writes JSON
        cloud = o3d.io.read_point_cloud(str(path), format="ply", remove_nan_points=False,
                                        remove_infinite_points=False)
    if len(cloud.points) != vertices:
        raise CloudFileError(path, f"truncated or corrupt: {len(cloud.points)} of {vertices} points could be read")
    return PointCloud.from_open3d(cloud)


def _quiet(o3d: Any) -> Any:
    """Open3D's own messages off (errors only) for the duration of a call."""
    return o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error)


class FileSource(FrameSource):
    """One cloud file, or every cloud file of a folder in name order."""

    kind = "3d"
    extensions = CLOUD_SUFFIXES
    folders = True
    summary = "a .pcd or .ply file, or a folder of them"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> FileSource:
        return cls(spec.text)

    def __init__(self, spec: str) -> None:
        self.name = spec
        path = Path(spec)
        if path.is_dir():
            self.paths = sorted(p for p in path.iterdir() if p.suffix.lower() in CLOUD_SUFFIXES)
            if not self.paths:
                raise SourceError(f"{spec}: the folder holds no .pcd or .ply files")
        elif path.is_file():
            if path.suffix.lower() not in CLOUD_SUFFIXES:
                raise SourceError(f"{spec}: not a point-cloud file (.pcd or .ply)")
            self.paths = [path]
        else:
            raise SourceError(f"{spec}: no such file or folder")

    @property
    def length(self) -> int:
        return len(self.paths)

    @property
    def seekable(self) -> bool:
        return True

    def __iter__(self) -> Iterator[Frame]:
        return self.frames_from(0)

    def frames_from(self, index: int) -> Iterator[Frame]:
        """From the ``index``-th file on; each frame's ``source`` is its file, so a viewer can name it."""
        start = max(0, index)
        for number, path in enumerate(self.paths[start:], start):
            cloud = read_cloud(path)
            yield Frame(cloud, stamp=path.stat().st_mtime, index=number, source=str(path))


class DemoSource(FrameSource):
    """The synthetic scene, endless unless ``frames`` is given (the sphere rolls; new noise each frame)."""

    kind = "3d"
    schemes = ("demo",)
    options = {  # noqa: RUF012 - declarations, never mutated
        "seed": Int(0, "random seed of the scene's layout and noise", min=0, max=2**31 - 1),
        "frames": Int(0, "how many frames (0: endless)", min=0),
    }
    positional = ("seed",)
    summary = "demo[:seed=N,frames=N], a table with a cylinder, a sphere and clutter, with ground truth"
    FPS = 30.0

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> DemoSource:
        return cls(spec.text, options["seed"], options["frames"] or None)

    def __init__(self, spec: str = "demo", seed: int = 0, frames: int | None = None) -> None:
        self.name = spec
        self.seed = seed
        self.frames = frames

    @property
    def length(self) -> int | None:
        return self.frames

    @property
    def rate(self) -> float:
        return self.FPS

    def __iter__(self) -> Iterator[Frame]:
        from .demo import demo_scene

        start = time.time()
        index = 0
        while self.frames is None or index < self.frames:
            cloud, truth = demo_scene(self.seed, index)
            yield Frame(cloud, stamp=start + index / self.FPS, index=index, source=self.name, truth=truth)
            index += 1


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
                data = json.loads(Path(self.intrinsics).read_text(encoding="utf-8"))
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
