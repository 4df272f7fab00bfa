"""The PLY reader: the vertices of an ascii or binary PLY file as a :class:`PointCloud`.

Read by NumPy through strictio (never by Open3D), after the header is checked: the vertex count against the
cloud-points limit before anything is allocated, the body's length against it, every ascii line as numbers (a
bad one named by its line number). The ascii number parsing is the PCD reader's (``objrec3d.pcd``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from strictio import CLOUD_POINTS, InputError, read_bytes
from strictio.limits import check
from strictio.shown import printable

from .cloud import PointCloud
from .pcd import MAX_HEADER_BYTES, MAX_PCD_BYTES, CloudFileError, ascii_rows, line_end

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
        raise CloudFileError(path, f"element {printable(lists[0])} has list properties where vertices are read "
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
                raise CloudFileError(path, f"{where}: unknown format '{printable(fmt)}' (ascii, binary_little_endian "
                                           "or binary_big_endian)")
        elif parts[0] == "element" and len(parts) == 3:
            count = parts[2]
            if not count.isdigit() or len(count) > 20:
                raise CloudFileError(path, f"{where}: element {printable(parts[1])} count "
                                           f"'{printable(count, 24)}' is not a whole number")
            elements.append(_PlyElement(parts[1], int(count)))
            if parts[1] == "vertex":
                check(path, CLOUD_POINTS, int(count), "element vertex", "header")  # before anything is allocated
        elif parts[0] == "property" and elements and len(parts) in (3, 5) and (len(parts) == 5) == (parts[1] == "list"):
            name, kind = parts[-1], None if len(parts) == 5 else _PLY_TYPES.get(parts[1])
            if kind is None and len(parts) == 3:
                raise CloudFileError(path, f"{where}: property {printable(name)} has unknown type "
                                           f"'{printable(parts[1])}'")
            if name in dict(elements[-1].properties):
                raise CloudFileError(path, f"{where}: property {printable(name)} occurs twice in element "
                                           f"{printable(elements[-1].name)}")
            elements[-1].properties.append((name, kind))
        else:
            raise CloudFileError(path, f"{where}: '{printable(line)}' is not a PLY header line")
    if not fmt:
        raise CloudFileError(path, "corrupt PLY header: no format line")
    return fmt, elements, offset
