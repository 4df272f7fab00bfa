"""Small code that makes hostile input files: decompression bombs, lying headers, YAML bombs, broken
clouds. Each file is small on disk; what makes it hostile is what it claims.
"""

from __future__ import annotations

import base64
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_CHUNK = 1 << 20


def zeros_deflate(length: int) -> bytes:
    """A zlib stream of ``length`` zero bytes, made without compressing them all: after a full flush the
    compressor starts afresh, so every further megabyte of zeros compresses to the same bytes."""
    compressor = zlib.compressobj(9)
    head = compressor.compress(bytes(_CHUNK)) + compressor.flush(zlib.Z_FULL_FLUSH)
    block = compressor.compress(bytes(_CHUNK)) + compressor.flush(zlib.Z_FULL_FLUSH)
    whole, rest = divmod(length, _CHUNK)
    if whole < 2:
        return zlib.compress(bytes(length), 9)
    tail = compressor.compress(bytes(rest)) + compressor.flush(zlib.Z_FINISH)
    adler = ((length % 65521) << 16) | 1  # Adler-32 of zeros: a stays 1, b adds 1 per byte
    return head + block * (whole - 1) + tail[:-4] + struct.pack(">I", adler)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_bomb(width: int, height: int, channels: int = 1) -> bytes:
    """A valid 8-bit PNG of ``width`` x ``height`` black pixels: a few hundred kilobytes that decode to
    ``width * height * channels`` bytes."""
    colour = {1: 0, 3: 2, 4: 6}[channels]
    header = struct.pack(">IIBBBBB", width, height, 8, colour, 0, 0, 0)
    raw_length = height * (1 + width * channels)  # each row: filter byte 0, then the zero samples
    return (_PNG_SIGNATURE + _png_chunk(b"IHDR", header) + _png_chunk(b"IDAT", zeros_deflate(raw_length))
            + _png_chunk(b"IEND", b""))


def sparse_pgm(path: Path, width: int, height: int) -> Path:
    """A binary PGM whose body is a hole in the file: its full size on paper, nothing on the disk."""
    header = f"P5\n{width} {height}\n255\n".encode("ascii")
    with open(path, "wb") as stream:
        stream.write(header)
        stream.truncate(len(header) + width * height)
    return path


def feature_file_with_target(shipped: Path, png: bytes) -> str:
    """The shipped feature system with its embedded target image replaced by ``png``."""
    lines = shipped.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == "image: !!binary |")
    indent = " " * (len(lines[start]) - len(lines[start].lstrip()) + 2)
    end = start + 1
    while end < len(lines) and lines[end].startswith(indent):
        end += 1
    encoded = base64.encodebytes(png).decode("ascii").split()
    return "\n".join([*lines[: start + 1], *(indent + row for row in encoded), *lines[end:]]) + "\n"


def with_value(shipped: Path, key: str, value: str) -> str:
    """A shipped YAML file with the first ``key:`` line's value replaced by ``value`` (as raw YAML text)."""
    out, done = [], False
    for line in shipped.read_text(encoding="utf-8").splitlines():
        stripped = line.lstrip()
        if not done and stripped.startswith(f"{key}:"):
            line = line[: len(line) - len(stripped)] + f"{key}: {value}"
            done = True
        out.append(line)
    assert done, f"{shipped} has no {key}"
    return "\n".join(out) + "\n"


def billion_laughs(levels: int = 9, width: int = 10) -> str:
    """Nested aliases: ``width ** levels`` strings from a few hundred bytes."""
    rows = [f"l0: &l0 [{', '.join(['lol'] * width)}]"]
    rows += [f"l{n}: &l{n} [{', '.join([f'*l{n - 1}'] * width)}]" for n in range(1, levels)]
    return "\n".join(rows) + "\n"


def deeply_nested(depth: int = 100_000) -> str:
    """A flow sequence nested ``depth`` levels deep."""
    return "[" * depth + "]" * depth + "\n"


def map_yaml(image: str, extra: str = "") -> str:
    """A map YAML around ``image``, the fields of the shipped B5.2.03 map."""
    return (f"image: {image}\nmode: trinary\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
            f"occupied_thresh: 0.65\nfree_thresh: 0.196\n{extra}")


def pcd_text_header(fields: str, sizes: str, types: str, counts: str, width: int, height: int,
                    encoding: str, comments: int = 0) -> bytes:
    head = [f"# comment line {i}" for i in range(comments)]
    head += ["VERSION 0.7", f"FIELDS {fields}", f"SIZE {sizes}", f"TYPE {types}", f"COUNT {counts}",
             f"WIDTH {width}", f"HEIGHT {height}", "VIEWPOINT 0 0 0 1 0 0 0", f"POINTS {width * height}",
             f"DATA {encoding}"]
    return ("\n".join(head) + "\n").encode("ascii")


def scene_points(count: int = 400, seed: int = 1) -> np.ndarray:
    """Points spread in front of a camera, inside the shipped shape system's distance range."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.3, 0.3, count), rng.uniform(-0.3, 0.3, count),
                            rng.uniform(0.6, 1.2, count)]).astype(np.float32)


def binary_pcd(points: np.ndarray, width: int | None = None, height: int = 1, comments: int = 0) -> bytes:
    """A plain binary PCD of x y z float32."""
    width = len(points) // height if width is None else width
    return (pcd_text_header("x y z", "4 4 4", "F F F", "1 1 1", width, height, "binary", comments)
            + np.ascontiguousarray(points, dtype="<f4").tobytes())


def identical_points_pcd(width: int = 640, height: int = 480) -> bytes:
    """An organized scan whose every point is the same point (what a frozen sensor gives)."""
    return binary_pcd(np.tile(np.array([[0.05, -0.02, 0.9]], np.float32), (width * height, 1)), width, height)


def compressed_pcd_claiming(points: int) -> bytes:
    """A binary_compressed PCD (x y z rgb) whose header and size header claim ``points`` points; its LZF
    data is a short literal run."""
    literal = b"\x1f" + bytes(32)  # LZF: a control byte 31 means 32 literal bytes follow
    sizes = struct.pack("<II", len(literal), points * 16)
    return pcd_text_header("x y z rgb", "4 4 4 4", "F F F U", "1 1 1 1", points, 1, "binary_compressed") \
        + sizes + literal


def ascii_ply(points: np.ndarray, comments: int = 0, body: bytes | None = None) -> bytes:
    head = ["ply", "format ascii 1.0", *(f"comment padding line {i:04d} of a long header" for i in range(comments)),
            f"element vertex {len(points)}", "property float x", "property float y", "property float z",
            "end_header"]
    text = body if body is not None else "".join(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in points).encode()
    return ("\n".join(head) + "\n").encode("ascii") + text


def demo_picture(seed: int = 0) -> np.ndarray:
    """A textured colour picture with a few saturated blobs (what the HSV system finds)."""
    rng = np.random.default_rng(seed)
    image = rng.integers(90, 140, (240, 320, 3), dtype=np.uint8)
    for k in range(4):
        cv2.circle(image, (40 + 70 * k, 120), 22, (30 * k, 40, 220), -1)
    return image


def truncated_jpeg() -> bytes:
    ok, data = cv2.imencode(".jpg", demo_picture(), [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    return data.tobytes()[: len(data) // 2]


def truncated_avi(path: Path, frames: int = 30) -> Path:
    """An MJPG AVI of ``frames`` frames, cut in the middle of its frame data (its index lost with it)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (320, 240))
    for seed in range(frames):
        writer.write(demo_picture(seed))
    writer.release()
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return path
