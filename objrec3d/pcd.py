"""Reading and writing PCD files (PCL's format): ascii, binary and binary_compressed (LZF).

Our own reader rather than Open3D's: Open3D drops the width x height layout that makes normals fast, and
a reader of our own can say precisely what is wrong with a corrupt or truncated file.
"""

from __future__ import annotations

import logging
import os
import struct
from pathlib import Path

import numpy as np

from objrec_core import SourceError

from .cloud import PointCloud
from .lzf import LZFError, lzf_decompress, lzf_store

log = logging.getLogger(__name__)

_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "u1", ("U", 2): "<u2", ("U", 4): "<u4", ("U", 8): "<u8",
          ("I", 1): "i1", ("I", 2): "<i2", ("I", 4): "<i4", ("I", 8): "<i8"}
_MAX_HEADER_LINES = 64


class CloudFileError(SourceError):
    """A point-cloud file that cannot be read; the message names the file and the problem."""

    def __init__(self, path: str | os.PathLike[str], problem: str) -> None:
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


def read_pcd(path: str | os.PathLike[str]) -> PointCloud:
    """Read a PCD file into a PointCloud, keeping its width x height layout and rgb/rgba colours."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise CloudFileError(path, "file not found") from None
    except OSError as exc:
        raise CloudFileError(path, f"cannot be read: {exc.strerror or exc}") from None
    header, offset = _parse_header(path, raw)
    fields, dtype, width, height, points, encoding = header
    body = memoryview(raw)[offset:]
    if encoding == "ascii":
        table = _read_ascii(path, body, dtype, points)
    elif encoding == "binary":
        need = points * dtype.itemsize
        if len(body) < need:
            raise CloudFileError(path, f"truncated: binary data has {len(body)} bytes, {points} points need {need}")
        table = np.frombuffer(body, dtype=dtype, count=points)
    else:
        table = _read_compressed(path, body, dtype, points)
    return _to_cloud(path, table, fields, width, height)


def _parse_header(path: Path, raw: bytes) -> tuple[tuple, int]:
    entries: dict[str, list[str]] = {}
    offset = 0
    for _ in range(_MAX_HEADER_LINES):
        end = raw.find(b"\n", offset)
        if end < 0:
            raise CloudFileError(path, "not a PCD file: the header has no DATA line")
        try:
            line = raw[offset:end].decode("ascii").strip()
        except UnicodeDecodeError:
            raise CloudFileError(path, "not a PCD file: the header is not text") from None
        offset = end + 1
        if not line or line.startswith("#"):
            continue
        key, *values = line.split()
        entries[key.upper()] = values
        if key.upper() == "DATA":
            break
    else:
        raise CloudFileError(path, "not a PCD file: no DATA line in the first lines")
    for key in ("FIELDS", "SIZE", "TYPE", "WIDTH", "DATA"):
        if key not in entries:
            raise CloudFileError(path, f"not a PCD file: the header has no {key} line")
    fields = entries["FIELDS"]
    sizes, types = entries["SIZE"], entries["TYPE"]
    counts = entries.get("COUNT", ["1"] * len(fields))
    if not (len(fields) == len(sizes) == len(types) == len(counts)):
        raise CloudFileError(path, "corrupt header: FIELDS, SIZE, TYPE and COUNT have different lengths")
    try:
        width = int(entries["WIDTH"][0])
        height = int(entries.get("HEIGHT", ["1"])[0])
        points = int(entries.get("POINTS", [str(width * height)])[0])
        sizes_i, counts_i = [int(s) for s in sizes], [int(c) for c in counts]
    except (ValueError, IndexError):
        raise CloudFileError(path, "corrupt header: WIDTH, HEIGHT, POINTS, SIZE and COUNT must be integers") from None
    if width < 0 or height < 0 or points != width * height:
        raise CloudFileError(path, f"corrupt header: POINTS {points} is not WIDTH {width} x HEIGHT {height}")
    descr = []
    for name, size, kind, count in zip(fields, sizes_i, types, counts_i, strict=True):
        code = _TYPES.get((kind.upper(), size))
        if code is None or count < 1:
            raise CloudFileError(path, f"corrupt header: field {name} has unsupported TYPE {kind} SIZE {size}")
        descr.append((name, code, (count,)) if count > 1 else (name, code))
    try:
        dtype = np.dtype(descr)
    except (ValueError, TypeError) as exc:
        raise CloudFileError(path, f"corrupt header: {exc}") from None
    encoding = entries["DATA"][0].lower() if entries["DATA"] else ""
    if encoding not in ("ascii", "binary", "binary_compressed"):
        raise CloudFileError(path, f"unknown DATA encoding {encoding!r} (ascii, binary or binary_compressed)")
    for axis in "xyz":
        if axis not in fields:
            raise CloudFileError(path, f"no {axis} field (fields: {' '.join(fields)})")
    return (fields, dtype, width, height, points, encoding), offset


def _read_ascii(path: Path, body: memoryview, dtype: np.dtype, points: int) -> np.ndarray:
    try:
        values = np.array(bytes(body).split(), dtype=np.float64)
    except ValueError:
        raise CloudFileError(path, "corrupt ascii data: a value is not a number") from None
    columns = sum(int(np.prod(dtype[name].shape)) or 1 for name in dtype.names)
    if values.size < points * columns:
        raise CloudFileError(path, f"truncated: ascii data holds {values.size // max(columns, 1)} of {points} points")
    if values.size > points * columns:
        raise CloudFileError(path, f"corrupt ascii data: more values than {points} points x {columns} columns")
    table = np.zeros(points, dtype=dtype)
    values = values.reshape(points, columns)
    col = 0
    for name in dtype.names:
        count = int(np.prod(dtype[name].shape)) or 1
        block = values[:, col : col + count]
        base = dtype[name].base
        if np.issubdtype(base, np.integer) and name in ("rgb", "rgba"):
            block = block.astype(np.uint64)
        table[name] = block.reshape(table[name].shape).astype(base)
        col += count
    # PCL writes a float-typed rgb as the float whose bits are the colour; ascii keeps those bits.
    return table


def _read_compressed(path: Path, body: memoryview, dtype: np.dtype, points: int) -> np.ndarray:
    if len(body) < 8:
        raise CloudFileError(path, "truncated: binary_compressed data has no size header")
    compressed, uncompressed = struct.unpack("<II", body[:8])
    need = points * dtype.itemsize
    if uncompressed != need:
        raise CloudFileError(path, f"corrupt: uncompressed size {uncompressed} bytes, {points} points need {need}")
    if len(body) - 8 < compressed:
        raise CloudFileError(path, f"truncated: {len(body) - 8} of {compressed} compressed bytes present")
    if points == 0:
        return np.zeros(0, dtype=dtype)
    try:
        data = lzf_decompress(body[8 : 8 + compressed], uncompressed)
    except LZFError as exc:
        raise CloudFileError(path, f"corrupt compressed data: {exc}") from None
    # binary_compressed stores each field for all points, one field after the other.
    table = np.zeros(points, dtype=dtype)
    start = 0
    for name in dtype.names:
        field = dtype[name]
        size = field.itemsize * points
        table[name] = np.frombuffer(data, dtype=field.base, count=points * (field.itemsize // field.base.itemsize),
                                    offset=start).reshape(table[name].shape)
        start += size
    return table


def _to_cloud(path: Path, table: np.ndarray, fields: list[str], width: int, height: int) -> PointCloud:
    xyz = np.empty((table.shape[0], 3), dtype=np.float32)
    for i, axis in enumerate("xyz"):
        xyz[:, i] = table[axis]
    colors = None
    for name in ("rgba", "rgb"):
        if name in fields:
            packed = np.ascontiguousarray(table[name]).view(np.uint32) if table[name].dtype.itemsize == 4 else None
            if packed is None:
                log.warning("%s: colour field %s is not 4 bytes wide; colours ignored", path, name)
                break
            bgra = packed.view(np.uint8).reshape(-1, 4)
            colors = bgra[:, 2::-1]  # B G R A in memory -> R G B
            break
    return PointCloud(xyz, colors, width, height)


def write_pcd(path: str | os.PathLike[str], cloud: PointCloud, encoding: str = "binary") -> None:
    """Write a cloud as PCD (x y z, plus rgb as PCL's packed U32 when coloured), layout included."""
    if encoding not in ("ascii", "binary", "binary_compressed"):
        raise ValueError(f"unknown PCD encoding {encoding!r}")
    n = len(cloud)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.colors is not None:
        fields.append(("rgb", "<u4"))
    table = np.zeros(n, dtype=fields)
    for i, axis in enumerate("xyz"):
        table[axis] = cloud.points[:, i]
    if cloud.colors is not None:
        c = cloud.colors.astype(np.uint32)
        table["rgb"] = (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]
    names = " ".join(name for name, _ in fields)
    header = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        f"FIELDS {names}\nSIZE {' '.join('4' for _ in fields)}\n"
        f"TYPE {' '.join('U' if name == 'rgb' else 'F' for name, _ in fields)}\nCOUNT {' '.join('1' for _ in fields)}\n"
        f"WIDTH {cloud.width}\nHEIGHT {cloud.height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {encoding}\n"
    ).encode("ascii")
    if encoding == "ascii":
        lines = []
        for row in table:
            values = [f"{row[a]:.8g}" for a in "xyz"]
            if cloud.colors is not None:
                values.append(str(int(row["rgb"])))
            lines.append(" ".join(values))
        body = ("\n".join(lines) + ("\n" if lines else "")).encode("ascii")
    elif encoding == "binary":
        body = table.tobytes()
    else:
        planar = b"".join(np.ascontiguousarray(table[name]).tobytes() for name, _ in fields)
        packed = lzf_store(planar)
        body = struct.pack("<II", len(packed), len(planar)) + packed
    Path(path).write_bytes(header + body)
