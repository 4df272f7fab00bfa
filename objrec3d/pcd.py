"""Reading and writing PCD files (PCL's format): ascii, binary and binary_compressed (LZF).

The header is parsed and checked here, so a corrupt or truncated file is refused with a message that names
the file and the problem, and the width x height layout that makes normals fast is kept (Open3D's reader
drops it). The LZF body of binary_compressed files, and the binary encodings when writing, go through
``pypcd4`` (with the C LZF codec of python-neo-lzf); ascii and plain binary bodies are read by NumPy.
"""

from __future__ import annotations

import io
import logging
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from objrec_core import SourceError
from strictio import InputError, read_bytes, write_atomically

from .cloud import PointCloud

log = logging.getLogger(__name__)

ENCODINGS = ("ascii", "binary", "binary_compressed")
#: The largest PCD file read: far above a scan (a 640 x 480 x y z rgb scan is 5 MB), below exhausting memory.
MAX_PCD_BYTES = 2 * 1024**3

_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "u1", ("U", 2): "<u2", ("U", 4): "<u4", ("U", 8): "<u8",
          ("I", 1): "i1", ("I", 2): "<i2", ("I", 4): "<i4", ("I", 8): "<i8"}
_MAX_HEADER_LINES = 64
_SINGLE_VALUED = ("x", "y", "z", "rgb", "rgba")  # the fields a PointCloud takes; each must have COUNT 1


class CloudFileError(SourceError):
    """A point-cloud file that cannot be read; the message names the file and the problem."""

    def __init__(self, path: str | os.PathLike[str], problem: str) -> None:
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


@dataclass(frozen=True)
class _Header:
    """What the header says: fields with their PCD size, type and count, the layout and the encoding."""

    fields: list[str]
    sizes: list[int]
    types: list[str]
    counts: list[int]
    width: int
    height: int
    encoding: str
    dtype: np.dtype

    @property
    def points(self) -> int:
        return self.width * self.height


def read_pcd(path: str | os.PathLike[str]) -> PointCloud:
    """Read a PCD file into a PointCloud, keeping its width x height layout and rgb/rgba colours."""
    path = Path(path)
    try:
        raw = read_bytes(path, MAX_PCD_BYTES)
    except InputError as exc:
        raise CloudFileError(path, exc.message) from None
    header, offset = _parse_header(path, raw)
    body = memoryview(raw)[offset:]
    if header.encoding == "ascii":
        table = _read_ascii(path, body, header.dtype, header.points)
        columns = {name: table[name] for name in _SINGLE_VALUED if name in header.fields}
    elif header.encoding == "binary":
        need = header.points * header.dtype.itemsize
        if len(body) < need:
            raise CloudFileError(path, f"truncated: binary data has {len(body)} bytes, "
                                       f"{header.points} points need {need}")
        table = np.frombuffer(body, dtype=header.dtype, count=header.points)
        columns = {name: table[name] for name in _SINGLE_VALUED if name in header.fields}
    else:
        columns = _read_compressed(path, body, header)
    return _to_cloud(path, columns, header.width, header.height)


def _parse_header(path: Path, raw: bytes) -> tuple[_Header, int]:
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
    sizes, types = entries["SIZE"], [kind.upper() for kind in entries["TYPE"]]
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
        code = _TYPES.get((kind, size))
        if code is None or count < 1:
            raise CloudFileError(path, f"corrupt header: field {name} has unsupported TYPE {kind} SIZE {size}")
        if count != 1 and name in _SINGLE_VALUED:
            raise CloudFileError(path, f"corrupt header: field {name} has COUNT {count}; it must be 1")
        descr.append((name, code, (count,)) if count > 1 else (name, code))
    try:
        dtype = np.dtype(descr)
    except (ValueError, TypeError) as exc:
        raise CloudFileError(path, f"corrupt header: {exc}") from None
    encoding = entries["DATA"][0].lower() if entries["DATA"] else ""
    if encoding not in ENCODINGS:
        raise CloudFileError(path, f"unknown DATA encoding {encoding!r} (ascii, binary or binary_compressed)")
    for axis in "xyz":
        if axis not in fields:
            raise CloudFileError(path, f"no {axis} field (fields: {' '.join(fields)})")
    return _Header(fields, sizes_i, types, counts_i, width, height, encoding, dtype), offset


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


def _read_compressed(path: Path, body: memoryview, header: _Header) -> dict[str, np.ndarray]:
    """Check the sizes the body declares, then let pypcd4 decompress it and split its field-by-field planes."""
    points = header.points
    if points == 0:
        return {name: np.zeros(0, header.dtype[name]) for name in _SINGLE_VALUED if name in header.fields}
    if len(body) < 8:
        raise CloudFileError(path, "truncated: binary_compressed data has no size header")
    compressed, uncompressed = struct.unpack("<II", body[:8])
    need = points * header.dtype.itemsize
    if uncompressed != need:
        raise CloudFileError(path, f"corrupt: uncompressed size {uncompressed} bytes, {points} points need {need}")
    if len(body) - 8 < compressed:
        raise CloudFileError(path, f"truncated: {len(body) - 8} of {compressed} compressed bytes present")
    pypcd4 = _pypcd4(path, "reading binary_compressed PCD")
    # pypcd4 is given a header it composes itself from what was checked here, with neutral field names: its
    # own parser reads at most 10 header lines, needs COUNT and POINTS and renames "_" padding fields.
    meta = _metadata(pypcd4, [f"f{i}" for i in range(len(header.fields))], header.sizes, header.types,
                     header.counts, header.width, header.height)
    stream = io.BytesIO(meta.compose_header().encode("ascii") + body[: 8 + compressed])
    try:
        table = pypcd4.PointCloud.from_fileobj(stream).pc_data
    except (ValueError, RuntimeError) as exc:  # lzf: a bad stream; pypcd4: fewer bytes than declared
        raise CloudFileError(path, f"corrupt compressed data: {exc}") from None
    except TypeError:  # lzf gives None where the output outgrows the declared size; pypcd4 takes its len()
        raise CloudFileError(path, f"corrupt compressed data: it decompresses to more than the {uncompressed} "
                                   "bytes its size header declares") from None
    return {name: table[f"f{i}"] for i, name in enumerate(header.fields) if name in _SINGLE_VALUED}


def _to_cloud(path: Path, columns: dict[str, np.ndarray], width: int, height: int) -> PointCloud:
    xyz = np.empty((len(columns["x"]), 3), dtype=np.float32)
    for i, axis in enumerate("xyz"):
        xyz[:, i] = columns[axis]
    colors = None
    for name in ("rgba", "rgb"):
        if name in columns:
            packed = np.ascontiguousarray(columns[name])
            if packed.dtype.itemsize != 4:
                log.warning("%s: colour field %s is not 4 bytes wide; colours ignored", path, name)
                break
            bgra = packed.view(np.uint32).view(np.uint8).reshape(-1, 4)
            colors = bgra[:, 2::-1]  # B G R A in memory -> R G B
            break
    return PointCloud(xyz, colors, width, height)


def write_pcd(path: str | os.PathLike[str], cloud: PointCloud, encoding: str = "binary") -> None:
    """Write a cloud as PCD (x y z, plus rgb as PCL's packed U32 when coloured), layout included.

    The file is replaced whole or not at all (a temporary file, then ``os.replace``); OutputError says why
    it could not be saved.
    """
    if encoding not in ENCODINGS:
        raise ValueError(f"unknown PCD encoding {encoding!r}")
    pypcd4 = _pypcd4(path, "writing PCD")
    n = len(cloud)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if cloud.colors is not None:
        fields.append(("rgb", "<u4"))
    table = np.empty(n, dtype=fields)
    for i, axis in enumerate("xyz"):
        table[axis] = cloud.points[:, i]
    if cloud.colors is not None:
        c = cloud.colors.astype(np.uint32)
        table["rgb"] = (c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]
    names = [name for name, _ in fields]
    meta = _metadata(pypcd4, names, [4] * len(names), ["U" if name == "rgb" else "F" for name in names],
                     [1] * len(names), cloud.width, cloud.height)
    stream = io.BytesIO()
    if encoding == "ascii":
        stream.write(meta.compose_header(pypcd4.Encoding.ASCII).encode("ascii"))
        stream.write(_ascii_lines(table))
    else:
        # Data that LZF cannot shrink is written as binary, a valid PCD too; the tail is cut after that rewrite.
        pypcd4.PointCloud(meta, table).save(stream, pypcd4.Encoding(encoding))
        stream.truncate()
    write_atomically(path, stream.getvalue())
    log.debug("wrote %d points to %s (%s)", n, path, encoding)


def _ascii_lines(table: np.ndarray) -> bytes:
    """One line per point; %.9g gives back every float32 exactly, unsigned fields are written as integers."""
    line = " ".join("%u" if table.dtype[name].kind == "u" else "%.9g" for name in table.dtype.names) + "\n"
    rows = zip(*(table[name].tolist() for name in table.dtype.names), strict=True)
    return "".join(map(line.__mod__, rows)).encode("ascii")


def _metadata(pypcd4: ModuleType, fields: list[str], sizes: list[int], types: list[str], counts: list[int],
              width: int, height: int) -> Any:
    return pypcd4.MetaData(fields=tuple(fields), size=tuple(sizes), type=tuple(types), count=tuple(counts),
                           points=width * height, width=width, height=height)


def _pypcd4(path: str | os.PathLike[str], what: str) -> ModuleType:
    """pypcd4, imported when first needed (it brings pydantic, which ``import objrec3d`` should not wait for)."""
    try:
        import pypcd4
    except ImportError:
        raise CloudFileError(path, f"{what} needs pypcd4, which is not installed: pip install 'objrec[3d]'") from None
    return pypcd4
