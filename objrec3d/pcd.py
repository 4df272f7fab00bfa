"""Reading and writing PCD files (PCL's format): ascii, binary and binary_compressed (LZF).

The header is parsed and checked here, so a corrupt or truncated file is refused with a message that names
the file and the problem (the field, the line), and the width x height layout that makes normals fast is kept
(Open3D's reader drops it). What a header claims is checked before anything is allocated for it: the points
against ``strictio.limits.CLOUD_POINTS``, a compressed body's sizes against what LZF can possibly give. The
LZF body of binary_compressed files, and the binary encodings when writing, go through ``pypcd4`` (with the C
LZF codec of python-neo-lzf); ascii and plain binary bodies are read by NumPy.
"""

from __future__ import annotations

import io
import logging
import os
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from objrec_core import SourceError
from strictio import CLOUD_POINTS, InputError, read_bytes, write_atomically
from strictio.limits import check
from strictio.shown import printable

from .cloud import PointCloud

log = logging.getLogger(__name__)

ENCODINGS = ("ascii", "binary", "binary_compressed")
#: The largest PCD file read: far above a scan (a 640 x 480 x y z rgb scan is 5 MB), below exhausting memory.
MAX_PCD_BYTES = 2 * 1024**3

_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "u1", ("U", 2): "<u2", ("U", 4): "<u4", ("U", 8): "<u8",
          ("I", 1): "i1", ("I", 2): "<i2", ("I", 4): "<i4", ("I", 8): "<i8"}
#: A header may be long (PCL tools write comment lines), but not endless: bounded by bytes, not lines.
MAX_HEADER_BYTES = 1024 * 1024
#: The largest point a header may declare: PCL's largest point types (descriptors) are a few kilobytes.
MAX_POINT_BYTES = 64 * 1024
#: LZF shrinks data at most about 88-fold (a 3-byte back-reference copies at most 264 bytes).
_LZF_MAX_RATIO = 100
_SINGLE_VALUED = ("x", "y", "z", "rgb", "rgba")  # the fields a PointCloud takes; each must have COUNT 1


class CloudFileError(SourceError, InputError):
    """A point-cloud file that cannot be read; the message names the file and the problem.

    A SourceError for the sources and an InputError for the commands, which report both the same way."""

    def __init__(self, path: str | os.PathLike[str], problem: str) -> None:
        self.problem = problem
        InputError.__init__(self, path, problem)


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
        table = _read_ascii(path, body, header.dtype, header.points, raw.count(b"\n", 0, offset))
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
    while True:
        end = raw.find(b"\n", offset, MAX_HEADER_BYTES)
        if end < 0:
            if len(raw) > MAX_HEADER_BYTES:
                raise CloudFileError(path, f"not a PCD file: no DATA line in its first {MAX_HEADER_BYTES:,} bytes")
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
    for key in ("FIELDS", "SIZE", "TYPE", "WIDTH", "DATA"):
        if key not in entries:
            raise CloudFileError(path, f"not a PCD file: the header has no {key} line")
    fields = entries["FIELDS"]
    sizes, types = entries["SIZE"], [kind.upper() for kind in entries["TYPE"]]
    counts = entries.get("COUNT", ["1"] * len(fields))
    if not (len(fields) == len(sizes) == len(types) == len(counts)):
        raise CloudFileError(path, "corrupt header: FIELDS, SIZE, TYPE and COUNT have different lengths")
    width = _whole(path, "WIDTH", entries["WIDTH"][:1])
    height = _whole(path, "HEIGHT", entries.get("HEIGHT", ["1"])[:1])
    points = _whole(path, "POINTS", entries["POINTS"][:1]) if "POINTS" in entries else width * height
    if points != width * height:
        raise CloudFileError(path, f"corrupt header: POINTS {points} is not WIDTH {width} x HEIGHT {height}")
    check(path, CLOUD_POINTS, points, "WIDTH x HEIGHT", "header")  # before anything is allocated for them
    descr = []
    point_bytes = 0
    for name, size_text, kind, count_text in zip(fields, sizes, types, counts, strict=True):
        size = _whole(path, f"SIZE of field {printable(name)}", [size_text])
        count = _whole(path, f"COUNT of field {printable(name)}", [count_text])
        code = _TYPES.get((kind, size))
        if code is None:
            raise CloudFileError(path, f"corrupt header: field {printable(name)} has unsupported TYPE "
                                       f"{printable(kind)} SIZE {size} (F 4/8, U or I 1/2/4/8)")
        if count < 1 or (count != 1 and name in _SINGLE_VALUED):
            must = "it must be 1" if name in _SINGLE_VALUED else "it must be at least 1"
            raise CloudFileError(path, f"corrupt header: field {printable(name)} has COUNT {count}; {must}")
        point_bytes += size * count
        if point_bytes > MAX_POINT_BYTES:
            raise CloudFileError(path, f"corrupt header: field {printable(name)} with COUNT {count} makes a point over "
                                       f"{MAX_POINT_BYTES:,} bytes")
        descr.append((name, code, (count,)) if count > 1 else (name, code))
    if len(set(fields)) != len(fields):
        twice = next(name for name in fields if fields.count(name) > 1)
        raise CloudFileError(path, f"corrupt header: field {printable(twice)} occurs more than once")
    try:
        dtype = np.dtype(descr)
    except (ValueError, TypeError) as exc:
        raise CloudFileError(path, f"corrupt header: {exc}") from None
    encoding = entries["DATA"][0].lower() if entries["DATA"] else ""
    if encoding not in ENCODINGS:
        raise CloudFileError(path, f"unknown DATA encoding '{printable(encoding)}' "
                                   "(ascii, binary or binary_compressed)")
    for axis in "xyz":
        if axis not in fields:
            raise CloudFileError(path, f"no {axis} field (fields: {printable(' '.join(fields), 80)})")
    sizes_i = [dtype[name].base.itemsize for name in fields]
    counts_i = [int(np.prod(dtype[name].shape)) or 1 for name in fields]
    return _Header(fields, sizes_i, types, counts_i, width, height, encoding, dtype), offset


def _whole(path: Path, what: str, values: list[str]) -> int:
    """A header's whole number, at least 0; CloudFileError names what it is and shows the value."""
    text = values[0] if values else ""
    if not text.isdigit() or len(text) > 20:  # no sign, no 5,000 digits: a count or a size
        raise CloudFileError(path, f"corrupt header: {what} '{printable(text, 24)}' is not a whole number")
    return int(text)


def _read_ascii(path: Path, body: memoryview, dtype: np.dtype, points: int, first_line: int) -> np.ndarray:
    columns = sum(int(np.prod(dtype[name].shape)) or 1 for name in dtype.names)
    values, rest = ascii_rows(path, body, columns, points, first_line)
    if bytes(rest).strip():
        raise CloudFileError(path, f"corrupt ascii data: more lines than the {points} points the header declares")
    table = np.zeros(points, dtype=dtype)
    col = 0
    for name in dtype.names:
        count = int(np.prod(dtype[name].shape)) or 1
        block = values[:, col : col + count]
        base = dtype[name].base
        with np.errstate(invalid="ignore", over="ignore"):  # NaN or 1e30 in an integer field: its bits, no warning
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
    if uncompressed > _LZF_MAX_RATIO * compressed + 64:  # before the decompressor allocates the claim
        raise CloudFileError(path, f"corrupt: {compressed:,} compressed bytes cannot decompress to the "
                                   f"{uncompressed:,} bytes the size header claims")
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


def ascii_rows(path: Path, data: bytes | memoryview, columns: int, rows: int, first_line: int = 0
               ) -> tuple[np.ndarray, memoryview]:
    """The first ``rows`` lines of ``data`` as a rows x columns float64 array, and the bytes after them.

    One point per line, as PCL and every PLY writer put them. A line that is not ``columns`` numbers is a
    CloudFileError naming its line number in the file (``first_line``: lines before ``data``).
    """
    data = memoryview(data).cast("B")
    end = line_end(data, rows)
    values = _numbers(data[:end], columns)
    if values is None:
        bad = _first_bad_line(data[:end], columns)
        line = bytes(data[bad[0] : bad[1]]).strip()
        tokens = len(line.split())
        number = first_line + bytes(data[: bad[0]]).count(b"\n") + 1
        if bad[1] == len(data) and tokens < columns:
            raise CloudFileError(path, f"truncated: line {number} ends after {tokens} of {columns} values")
        raise CloudFileError(path, f"corrupt ascii data: line {number} is not {columns} numbers: "
                                   f"'{printable(line.decode('latin-1'), 40)}'")
    if values.shape[0] < rows:
        raise CloudFileError(path, f"truncated: ascii data holds {values.shape[0]} of {rows} points")
    return values, data[end:]


def _numbers(data: memoryview, columns: int) -> np.ndarray | None:
    """Lines of ``columns`` numbers (blank lines skipped), or None when a line is anything else."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "input contained no data": zero rows, checked by the caller
        try:
            values = np.loadtxt(io.BytesIO(data), dtype=np.float64, comments=None, ndmin=2)
        except ValueError:
            return None
    if values.size == 0:
        return np.zeros((0, columns))
    return values if values.shape[1] == columns else None


def line_end(data: memoryview, lines: int) -> int:
    """The offset just past the ``lines``-th newline of ``data`` (its length when it has fewer), found a
    megabyte at a time: no array as large as the data."""
    if lines <= 0:
        return 0
    chunk, start, seen = 1 << 20, 0, 0
    while start < len(data):
        piece = bytes(data[start : start + chunk])
        found = piece.count(b"\n")
        if seen + found >= lines:
            at = np.flatnonzero(np.frombuffer(piece, np.uint8) == 10)[lines - seen - 1]
            return start + int(at) + 1
        seen += found
        start += chunk
    return len(data)


def _first_bad_line(data: memoryview, columns: int) -> tuple[int, int]:
    """Start and end offsets of the first line that is not ``columns`` numbers (bisection: a few parses)."""
    total = bytes(data).count(b"\n") + 1
    good, bad = 0, total  # the first `good` lines parse; the first `bad` lines do not
    while bad - good > 1:
        middle = (good + bad) // 2
        if _numbers(data[: line_end(data, middle)], columns) is None:
            bad = middle
        else:
            good = middle
    start = line_end(data, good)
    end = bytes(data).find(b"\n", start)
    return start, len(data) if end < 0 else end


def _to_cloud(path: Path, columns: dict[str, np.ndarray], width: int, height: int) -> PointCloud:
    xyz = np.empty((len(columns["x"]), 3), dtype=np.float32)
    with np.errstate(over="ignore", invalid="ignore"):  # a double or integer beyond float32: inf, an invalid point
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
