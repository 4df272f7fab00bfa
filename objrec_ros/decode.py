"""ROS sensor messages as NumPy arrays: ``sensor_msgs/Image``, ``sensor_msgs/PointCloud2`` and a depth image
with its ``sensor_msgs/CameraInfo`` made into an organized cloud.

NumPy only, vectorised: a message's byte buffer is viewed through a dtype built from its layout (row
``step`` with padding, ``point_step`` and field offsets), never walked point by point. Compressed images need
an image codec and are decoded by the kind that has one (``objrec2d.bag_source``). Every problem with a
message is a :class:`DecodeError` with a one-line reason; callers add the file, topic and message number.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from strictio import CLOUD_POINTS, LimitError
from strictio.limits import check

IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"

#: encoding -> (element dtype, channels). The 8UC*/16UC1 names are the OpenCV-style ones drivers also use.
IMAGE_ENCODINGS: dict[str, tuple[str, int]] = {
    "bgr8": ("u1", 3), "rgb8": ("u1", 3), "bgra8": ("u1", 4), "rgba8": ("u1", 4),
    "mono8": ("u1", 1), "mono16": ("u2", 1),
    "8uc1": ("u1", 1), "8uc3": ("u1", 3), "8uc4": ("u1", 4),
    "16uc1": ("u2", 1), "32fc1": ("f4", 1),
}
SUPPORTED = "bgr8, rgb8, bgra8, rgba8, mono8, mono16, 16UC1, 32FC1, 8UC1, 8UC3, 8UC4"
#: Encodings that hold depth (16-bit millimetres or float metres), not a picture.
DEPTH_ENCODINGS = frozenset({"16uc1", "32fc1"})

#: Points converted at a time: the temporaries of a 20-million-point cloud stay a few megabytes.
_BLOCK_POINTS = 1 << 18

#: PointField datatypes (sensor_msgs/PointField constants) as little-endian NumPy types.
POINT_FIELD_TYPES = {1: "i1", 2: "u1", 3: "<i2", 4: "<u2", 5: "<i4", 6: "<u4", 7: "<f4", 8: "<f8"}


class DecodeError(ValueError):
    """A message objrec cannot turn into an array: an unknown encoding, a short buffer, a big-endian cloud."""


def encoding_of(message: Any) -> str:
    """The image encoding in the lower-case form the tables here use."""
    return str(getattr(message, "encoding", "")).strip().lower()


def is_depth_encoding(encoding: str) -> bool:
    return encoding.strip().lower() in DEPTH_ENCODINGS


def _buffer(data: Any) -> np.ndarray:
    """A message's ``uint8[]`` field as a flat uint8 array (rosbags gives an ndarray; tests may give bytes)."""
    if isinstance(data, np.ndarray):
        return np.ascontiguousarray(data).reshape(-1).view(np.uint8)
    return np.frombuffer(bytes(data), dtype=np.uint8)


def _private(buffer: np.ndarray) -> bool:
    """Whether ``buffer`` lies in a ``bytearray`` read for this message alone (``objrec_ros.direct``), which the
    decoders may view or reuse: a caller's own array or the recording's read-only bytes are never changed."""
    owner: Any = buffer
    while isinstance(owner, np.ndarray) and owner.base is not None:
        owner = owner.base
    if isinstance(owner, memoryview):
        owner = owner.obj
    return isinstance(owner, bytearray) and buffer.flags.writeable


def _rows(data: np.ndarray, height: int, step: int, row: int, what: str) -> np.ndarray:
    """The ``row`` meaningful bytes of each of ``height`` rows ``step`` bytes apart, as a (height, row) array.

    The last row's padding may be missing (some writers stop at its last pixel)."""
    need = step * (height - 1) + row if height else 0
    if data.size < need:
        raise DecodeError(f"{what}: {data.size} bytes of data, {need} needed (truncated message?)")
    if step == row:
        return data[: height * row].reshape(height, row)
    if data.size < step * height:
        data = np.concatenate([data[:need], np.zeros(step * height - need, dtype=np.uint8)])
    return data[: step * height].reshape(height, step)[:, :row]


def image_array(message: Any) -> np.ndarray:
    """A ``sensor_msgs/Image`` as an array in its own encoding: H x W (one channel) or H x W x C, dtype uint8,
    uint16 or float32 in native byte order; ``step`` padding dropped, ``is_bigendian`` honoured.

    The frame owns its pixels: a view of the message's buffer where that buffer is the message's own (read by
    ``objrec_ros.direct``: a 300 MB image is not copied again), else a copy (read-only bytes, a caller's
    array, padded rows, the other byte order)."""
    encoding = encoding_of(message)
    if encoding not in IMAGE_ENCODINGS:
        raise DecodeError(f"image encoding {message.encoding!r} is not supported ({SUPPORTED})")
    kind, channels = IMAGE_ENCODINGS[encoding]
    height, width, step = int(message.height), int(message.width), int(message.step)
    if height <= 0 or width <= 0:
        raise DecodeError(f"empty image ({width} x {height})")
    element = np.dtype(kind)
    row = width * channels * element.itemsize
    if step < row:
        raise DecodeError(f"step {step} is shorter than one row of {width} {message.encoding} pixels ({row} bytes)")
    buffer = _buffer(message.data)
    rows = _rows(buffer, height, step, row, f"{width} x {height} {message.encoding} image")
    if element.itemsize > 1:
        element = element.newbyteorder(">" if message.is_bigendian else "<")
    pixels = np.ascontiguousarray(rows).view(element).reshape(height, width, channels)
    if not pixels.dtype.isnative:
        pixels = pixels.astype(pixels.dtype.newbyteorder("="))  # a copy in this machine's byte order
    elif np.may_share_memory(pixels, buffer) and not _private(buffer):
        pixels = pixels.copy()  # read-only bytes, or a caller's array: pixels of the frame's own
    return pixels[..., 0] if channels == 1 else pixels


def image_to_bgr(message: Any) -> np.ndarray:
    """A picture message as objrec's 2D frames are: BGR uint8 H x W x 3 for colour (alpha dropped), H x W
    uint8 for mono (``mono16`` scaled to 8 bits as cv_bridge does, by 1/256). Depth is refused: it is not a
    picture (the 3D bag source makes clouds of it)."""
    encoding = encoding_of(message)
    if encoding in DEPTH_ENCODINGS:
        raise DecodeError(f"{message.encoding} is a depth image, not a picture (read it as 3d data, with its "
                          "CameraInfo topic)")
    pixels = image_array(message)
    if encoding in ("rgb8", "rgba8"):
        return np.ascontiguousarray(pixels[..., 2::-1])
    if encoding in ("bgra8", "8uc4"):
        return np.ascontiguousarray(pixels[..., :3])
    if pixels.dtype == np.uint16:
        return (pixels >> 8).astype(np.uint8)
    return pixels


def image_to_rgb(message: Any) -> np.ndarray:
    """A picture message as RGB uint8 H x W x 3 (mono repeated into three channels): point colours."""
    bgr = image_to_bgr(message)
    if bgr.ndim == 2:
        return np.repeat(bgr[..., None], 3, axis=2)
    return np.ascontiguousarray(bgr[..., ::-1])


class CloudArrays(NamedTuple):
    """A decoded cloud: points (H x W x 3 organized, N x 3 otherwise, float32, NaN where invalid), RGB uint8
    colours of the same shape or None, and the layout."""

    points: np.ndarray
    colors: np.ndarray | None
    width: int
    height: int


def _field_table(message: Any) -> dict[str, tuple[int, str]]:
    """PointCloud2 fields by name: (offset, NumPy type), checked against ``point_step``."""
    point_step = int(message.point_step)
    table: dict[str, tuple[int, str]] = {}
    for field in message.fields:
        kind = POINT_FIELD_TYPES.get(int(field.datatype))
        if kind is None:
            raise DecodeError(f"field {field.name!r} has an unknown datatype {field.datatype}")
        offset = int(field.offset)
        end = offset + np.dtype(kind).itemsize * max(int(field.count), 1)
        if offset < 0 or end > point_step:
            raise DecodeError(f"field {field.name!r} (bytes {offset}..{end}) lies outside the point_step of "
                              f"{point_step} bytes")
        table[str(field.name)] = (offset, kind)
    return table


def pointcloud2_arrays(message: Any) -> CloudArrays:
    """A ``sensor_msgs/PointCloud2`` with x, y, z (any numeric type, any order and padding) and optionally a
    packed ``rgb``/``rgba`` (float32 or uint32, 0x00RRGGBB as PCL packs it) or separate ``r``/``g``/``b``
    fields. An organized cloud (height > 1) stays H x W. Big-endian data is refused.

    A message read by ``objrec_ros.direct`` is decoded in place: the points are packed into its own buffer (a
    20-million-point cloud costs its 320 MB once, not again for the points), so decode such a message once."""
    if message.is_bigendian:
        raise DecodeError("big-endian PointCloud2 data (is_bigendian is set) is not supported; publish or "
                          "convert the cloud little-endian")
    width, height = int(message.width), int(message.height)
    point_step, row_step = int(message.point_step), int(message.row_step)
    fields = _field_table(message)
    missing = [name for name in ("x", "y", "z") if name not in fields]
    if missing:
        raise DecodeError(f"PointCloud2 without field {', '.join(missing)} (fields: {', '.join(fields) or 'none'})")
    colour = next((name for name in ("rgb", "rgba") if name in fields), None)
    names = ["x", "y", "z"]
    formats = [fields[n][1] for n in names]
    if colour is not None:
        names.append(colour)
        formats.append("<u4")  # the packed bytes, whatever type the field declares
        if np.dtype(fields[colour][1]).itemsize != 4:
            raise DecodeError(f"field {colour!r} must be 4 bytes (float32 or uint32), got {fields[colour][1]}")
    elif all(c in fields for c in "rgb"):
        names += ["r", "g", "b"]
        formats += [fields[c][1] for c in "rgb"]
    n = width * height
    if n == 0:
        empty = np.empty((0, 3), dtype=np.float32)
        return CloudArrays(empty, None, 0, 1)
    try:  # before anything is allocated for the points
        check("PointCloud2", CLOUD_POINTS, n, f"{width} x {height} PointCloud2")
    except LimitError as exc:
        raise DecodeError(exc.message) from None
    if point_step <= 0:
        raise DecodeError(f"point_step {point_step} is not positive")
    row = width * point_step
    if row_step < row:
        raise DecodeError(f"row_step {row_step} is shorter than a row of {width} points of {point_step} bytes")
    buffer = _buffer(message.data)
    rows = _rows(buffer, height, row_step, row, f"{width} x {height} PointCloud2")
    layout = np.dtype({"names": names, "formats": formats, "offsets": [fields[n][0] for n in names],
                       "itemsize": point_step})
    table = np.ascontiguousarray(rows).reshape(-1).view(layout)
    # A private, writable buffer (a message read by objrec_ros.direct) holds the points in place: each block of
    # points is packed to x, y, z float32 at the buffer's start, which never reaches a point not yet read
    # (12 bytes per point written, point_step >= 12 read). Else the points get an array of their own.
    in_place = point_step >= 12 and sys.byteorder == "little" and np.may_share_memory(table, buffer) \
        and _private(buffer)
    points = buffer[: n * 12].view(np.float32).reshape(n, 3) if in_place else np.empty((n, 3), dtype=np.float32)
    colors = None if colour is None and "r" not in names else np.empty((n, 3), dtype=np.uint8)
    # float64 coordinates past float32's range become inf, NaN colour channels 0: a message's values, not an error
    with np.errstate(over="ignore", invalid="ignore"):
        for first in range(0, n, _BLOCK_POINTS):
            block = table[first:first + _BLOCK_POINTS]
            if colors is not None:  # before the block's points are packed over their colours
                if colour is not None:
                    packed = block[colour]
                    colors[first:first + len(block), 0] = (packed >> 16) & 0xFF
                    colors[first:first + len(block), 1] = (packed >> 8) & 0xFF
                    colors[first:first + len(block), 2] = packed & 0xFF
                else:
                    colors[first:first + len(block)] = np.stack(
                        [np.nan_to_num(np.clip(block[c], 0, 255)) for c in "rgb"], axis=-1)
            xyz = np.empty((len(block), 3), dtype=np.float32)
            for axis, name in enumerate(("x", "y", "z")):
                xyz[:, axis] = block[name]
            points[first:first + len(block)] = xyz
    if height > 1:
        points = points.reshape(height, width, 3)
        colors = None if colors is None else colors.reshape(height, width, 3)
    return CloudArrays(points, colors, width, height)


class Intrinsics(NamedTuple):
    """Pinhole intrinsics from a CameraInfo's K, with the image size it describes (0: not given)."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int = 0
    height: int = 0


def camera_intrinsics(message: Any) -> Intrinsics:
    """fx, fy, cx, cy from a ``sensor_msgs/CameraInfo`` (``k`` in ROS 2, ``K`` in ROS 1: row-major 3 x 3)."""
    k = getattr(message, "k", None)
    if k is None:
        k = getattr(message, "K", None)
    values = np.asarray(k if k is not None else (), dtype=np.float64).reshape(-1)
    if values.size != 9:
        raise DecodeError(f"CameraInfo K has {values.size} values, 9 expected")
    fx, fy, cx, cy = (float(values[i]) for i in (0, 4, 2, 5))
    if not (np.isfinite([fx, fy, cx, cy]).all() and fx > 0 and fy > 0):
        raise DecodeError(f"CameraInfo K is not a camera's (fx={fx}, fy={fy}): an uncalibrated camera?")
    return Intrinsics(fx, fy, cx, cy, int(getattr(message, "width", 0)), int(getattr(message, "height", 0)))


def depth_scale(encoding: str) -> float:
    """Units per metre of a depth encoding: 16-bit images are millimetres, float images metres."""
    return 1.0 if encoding.strip().lower() == "32fc1" else 1000.0


def depth_to_points(depth: np.ndarray, intrinsics: Intrinsics | Sequence[float], scale: float) -> np.ndarray:
    """Back-project an H x W depth image (``scale`` units per metre) into organized H x W x 3 float32 points,
    NaN where the depth is 0, negative or NaN: the arithmetic of objrec3d's RGB-D source, so the same pixels
    give the same points."""
    fx, fy, cx, cy = (float(v) for v in tuple(intrinsics)[:4])
    if depth.ndim != 2:
        raise DecodeError(f"a depth image has one channel, got shape {depth.shape}")
    h, w = depth.shape
    z = depth.astype(np.float32) / np.float32(scale)
    z[~(z > 0)] = np.nan
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    return np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=-1)


def depth_cloud(depth_message: Any, info_message: Any, color: np.ndarray | None = None) -> CloudArrays:
    """A depth ``Image`` (16UC1/mono16 millimetres, 32FC1 metres) and its ``CameraInfo`` as an organized
    cloud; ``color`` (RGB uint8 H x W x 3 of the same size) colours it."""
    encoding = encoding_of(depth_message)
    if encoding not in ("16uc1", "mono16", "32fc1"):
        raise DecodeError(f"image encoding {depth_message.encoding!r} is not depth (16UC1, mono16 or 32FC1)")
    depth = image_array(depth_message)
    intrinsics = camera_intrinsics(info_message)
    h, w = depth.shape
    if intrinsics.width and intrinsics.height and (intrinsics.width, intrinsics.height) != (w, h):
        raise DecodeError(f"CameraInfo is for {intrinsics.width} x {intrinsics.height} images, the depth image "
                          f"is {w} x {h}")
    if color is not None and color.shape[:2] != (h, w):
        raise DecodeError(f"colour image {color.shape[1]} x {color.shape[0]} and depth {w} x {h} differ")
    points = depth_to_points(depth, intrinsics, depth_scale(encoding))
    return CloudArrays(points, color, w, h)
