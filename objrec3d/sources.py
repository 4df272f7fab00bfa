"""Point-cloud sources (plug-ins of the ``objrec.sources`` group), named with the same grammar as every source.

- ``demo`` / ``demo:3`` / ``demo:seed=3,frames=50``: the synthetic scene (``demo.py``), with ground truth.
- ``PATH.pcd`` / ``PATH.ply``: one file; ``FOLDER``: every .pcd/.ply in it, in name order (one that cannot
  be read is skipped with a warning). Both formats are read by NumPy, through strictio.
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import Frame, FrameSource, Int, SourceError, SourceSpec, Str
from strictio import CLOUD_POINTS, InputError, read_bytes, read_text
from strictio.image_size import check_image_pixels
from strictio.limits import check

from .cloud import PointCloud
from .pcd import MAX_HEADER_BYTES, MAX_PCD_BYTES, CloudFileError, ascii_rows, line_end, read_pcd, shown

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


#: PLY property types as NumPy types (byte order added by the format).
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}


@dataclass
class _PlyElement:
    """One element of a PLY header: its name, how many it claims, and its properties (name, NumPy type;
    type None for a list property)."""

    name: str
    count: int
    properties: list[tuple[str, str | None]] = field(default_factory=list)


def read_ply(path: str | Path) -> PointCloud:
    """Read the vertices of a PLY file (ascii or binary): x, y, z and, when present, red, green, blue.

    Read by NumPy through strictio, after the header is checked: the vertex count against the cloud-points
    limit, the body's length against it, every ascii line as numbers (a bad one is named by its number)."""
    path = Path(path)
    try:
        raw = read_bytes(path, MAX_PCD_BYTES)
    except InputError as exc:
        raise CloudFileError(path, exc.message) from None
    fmt, elements, body_start = _ply_header(path, raw)
    vertex = next((e for e in elements if e.name == "vertex"), None)
    if vertex is None or vertex.count == 0:
        return PointCloud.empty()  # a valid file without points: an empty cloud, an empty detection
    for axis in "xyz":
        if axis not in dict(vertex.properties):
            raise CloudFileError(path, f"corrupt PLY header: element vertex has no property {axis}")
    before = elements[: elements.index(vertex)]
    lists = [e.name for e in [*before, vertex] if any(kind is None for _, kind in e.properties)]
    if lists and (fmt != "ascii" or vertex.name in lists):
        raise CloudFileError(path, f"element {shown(lists[0])} has list properties where vertices are read "
                                   "(not supported there)")
    names = [name for name, _ in vertex.properties]
    body = memoryview(raw)[body_start:]
    if fmt == "ascii":
        skip = line_end(body, sum(e.count for e in before))
        first_line = raw.count(b"\n", 0, body_start) + bytes(body[:skip]).count(b"\n")
        values, rest = ascii_rows(path, body[skip:], len(names), vertex.count, first_line)
        if vertex is elements[-1] and bytes(rest).strip():
            raise CloudFileError(path, f"corrupt: more lines than the {vertex.count} vertices the header declares")
        columns = {name: values[:, i] for i, name in enumerate(names)}
    else:
        order = _PLY_FORMATS[fmt]
        skip = sum(e.count * np.dtype([(n, order + str(k)) for n, k in e.properties]).itemsize for e in before)
        layout = np.dtype([(name, order + str(kind)) for name, kind in vertex.properties])
        need = skip + vertex.count * layout.itemsize
        if len(body) < need:
            raise CloudFileError(path, f"truncated: {len(body)} bytes of element data, {vertex.count} vertices "
                                       f"need {need}")
        table = np.frombuffer(body, dtype=layout, count=vertex.count, offset=skip)
        columns = {name: table[name] for name in names}
    with np.errstate(over="ignore"):  # 1e300 in a double: inf, an invalid point like NaN
        points = np.stack([columns[axis].astype(np.float32) for axis in "xyz"], axis=1)
    colors = None
    channels = ("red", "green", "blue")
    if all(c in columns for c in channels):
        rgb = np.stack([columns[c] for c in channels], axis=1).astype(np.float64)
        kinds = dict(vertex.properties)
        if any(str(kinds[c]).startswith("f") for c in channels):
            rgb *= 255.0  # float colours run from 0 to 1
        colors = np.clip(np.nan_to_num(rgb) + 0.5, 0, 255).astype(np.uint8)
    return PointCloud(points, colors)


def _ply_header(path: Path, raw: bytes) -> tuple[str, list[_PlyElement], int]:
    """The format, the elements and where the body starts; the vertex count checked against the limit."""
    if raw[:16].split(b"\n", 1)[0].strip() != b"ply":
        raise CloudFileError(path, "not a PLY file (it does not start with 'ply')")
    fmt, elements = "", []
    offset, number = 0, 0
    while True:
        end = raw.find(b"\n", offset, MAX_HEADER_BYTES)
        if end < 0:
            raise CloudFileError(path, f"corrupt PLY header: no end_header in its first {MAX_HEADER_BYTES:,} bytes"
                                 if len(raw) > MAX_HEADER_BYTES else "corrupt PLY header: no end_header")
        line = raw[offset:end].decode("ascii", "replace").strip()
        offset, number = end + 1, number + 1
        parts = line.split()
        if line == "end_header":
            break
        if number == 1 or not parts or parts[0] in ("comment", "obj_info"):
            continue
        where = f"corrupt PLY header: line {number}"
        if parts[0] == "format" and len(parts) == 3:
            fmt = parts[1]
            if fmt not in _PLY_FORMATS:
                raise CloudFileError(path, f"{where}: unknown format '{shown(fmt)}' (ascii, binary_little_endian "
                                           "or binary_big_endian)")
        elif parts[0] == "element" and len(parts) == 3:
            count = parts[2]
            if not count.isdigit() or len(count) > 20:
                raise CloudFileError(path, f"{where}: element {shown(parts[1])} count '{shown(count, 24)}' is not "
                                           "a whole number")
            elements.append(_PlyElement(parts[1], int(count)))
            if parts[1] == "vertex":
                check(path, CLOUD_POINTS, int(count), "element vertex", "header")  # before anything is allocated
        elif parts[0] == "property" and elements and len(parts) in (3, 5) and (len(parts) == 5) == (parts[1] == "list"):
            name, kind = parts[-1], None if len(parts) == 5 else _PLY_TYPES.get(parts[1])
            if kind is None and len(parts) == 3:
                raise CloudFileError(path, f"{where}: property {shown(name)} has unknown type '{shown(parts[1])}'")
            if name in dict(elements[-1].properties):
                raise CloudFileError(path, f"{where}: property {shown(name)} occurs twice in element "
                                           f"{shown(elements[-1].name)}")
            elements[-1].properties.append((name, kind))
        else:
            raise CloudFileError(path, f"{where}: '{shown(line)}' is not a PLY header line")
    if not fmt:
        raise CloudFileError(path, "corrupt PLY header: no format line")
    return fmt, elements, offset


def _quiet(o3d: Any) -> Any:
    """Open3D's own messages off (errors only) for the duration of a call."""
    return o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error)


class FileSource(FrameSource):
    """One cloud file, or every cloud file of a folder in name order.

    In a folder, a file that cannot be read is reported (one warning naming it and why) and skipped, as a
    folder of images does; only when none of them could be read is that an error. One file given alone that
    cannot be read is an error at once."""

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
        self.folder = path.is_dir()
        if self.folder:
            try:
                entries = list(path.iterdir())
            except OSError as exc:
                raise SourceError(f"{spec}: cannot list the folder: {exc.strerror or exc}") from None
            self.paths = sorted(p for p in entries if p.suffix.lower() in CLOUD_SUFFIXES)
            if not self.paths:
                raise SourceError(f"{spec}: the folder holds no .pcd or .ply files")
        elif path.exists():  # a FIFO or a device is refused by the reader, which says what it is
            if path.suffix.lower() not in CLOUD_SUFFIXES:
                raise SourceError(f"{spec}: not a point-cloud file (.pcd or .ply)")
            self.paths = [path]
        else:
            raise SourceError(f"{spec}: no such file or folder")
        #: The files of a folder that could not be read, in the order they were met.
        self.skipped: list[Path] = []

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
            if not self.folder:
                yield Frame(read_cloud(path), stamp=_stamp(path), index=number, source=str(path))
                continue
            try:
                cloud = read_cloud(path)
            except InputError as exc:  # CloudFileError and a limit's LimitError alike
                log.warning("%s, skipped", exc)
                if path not in self.skipped:
                    self.skipped.append(path)
                continue
            yield Frame(cloud, stamp=_stamp(path), index=number, source=str(path))
        if self.folder and len(self.skipped) == len(self.paths):
            raise SourceError(f"{self.name}: none of its {len(self.paths)} point-cloud files could be read")


def _stamp(path: Path) -> float:
    """When the file was written (0 when it went away meanwhile)."""
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0


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
