"""NumPy images to Qt and back: the one place that knows OpenCV's memory layout (BGR, masks).

Images from a pipeline are shown without copying where the layout allows: the QImage borrows the array's
buffer, so the caller must keep the array alive as long as the QImage (``ImageBuffer`` does that).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import cv2
import numpy as np
from PySide6.QtGui import QImage


def displayable(image: np.ndarray) -> np.ndarray:
    """An 8-bit grey or BGR image for any array a stage may produce (bool masks, depth, float maps)."""
    array = np.asarray(image)
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[:, :, 0]
    if array.ndim not in (2, 3) or (array.ndim == 3 and array.shape[2] not in (3, 4)):
        raise ValueError(f"not an image: array of shape {array.shape}")
    if array.dtype == np.bool_:
        return array.astype(np.uint8) * 255
    if array.dtype != np.uint8:
        finite = np.isfinite(array) if np.issubdtype(array.dtype, np.floating) else None
        values = array[finite] if finite is not None else array
        low, high = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
        scale = 255.0 / (high - low) if high > low else 0.0
        scaled = (np.nan_to_num(array.astype(np.float32), nan=low) - low) * scale
        array = np.clip(scaled, 0, 255).astype(np.uint8)
    if array.ndim == 3 and array.shape[2] == 4:
        array = cv2.cvtColor(array, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(array)


@dataclass(frozen=True)
class ImageBuffer:
    """A QImage together with the array that owns its pixels."""

    array: np.ndarray
    qimage: QImage

    @classmethod
    def from_array(cls, image: np.ndarray) -> ImageBuffer:
        array = displayable(image)
        height, width = array.shape[:2]
        fmt = QImage.Format.Format_Grayscale8 if array.ndim == 2 else QImage.Format.Format_BGR888
        return cls(array, QImage(array.data, width, height, array.strides[0], fmt))

    @property
    def width(self) -> int:
        return int(self.array.shape[1])

    @property
    def height(self) -> int:
        return int(self.array.shape[0])


def fit_size(width: int, height: int, area_width: int, area_height: int) -> tuple[int, int]:
    """The size of a width x height image scaled into an area with its aspect ratio kept."""
    scale = min(area_width / max(width, 1), area_height / max(height, 1))
    return max(1, round(width * scale)), max(1, round(height * scale))


def display_buffer(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``image`` resized to ``size`` (width, height) as 32-bit BGRX, the layout of QImage.Format_RGB32 on a
    little-endian machine: the window system then blits it without converting or scaling. Made in the
    processing thread (OpenCV releases the GIL), so the GUI thread only copies pixels."""
    array = displayable(image)
    width, height = size
    if (array.shape[1], array.shape[0]) != (width, height):
        # Bilinear down to half size (0.3 ms for 640x480); area averaging only below, where bilinear aliases.
        small = width < array.shape[1] // 2
        array = cv2.resize(array, (width, height), interpolation=cv2.INTER_AREA if small else cv2.INTER_LINEAR)
    code = cv2.COLOR_GRAY2BGRA if array.ndim == 2 else cv2.COLOR_BGR2BGRA
    return cv2.cvtColor(array, code)


#: Below this display scale a line a few pixels wide drawn on the picture would average away
#: (on a 55 MP photo shown in a 800 px view, the detections vanished).
THIN_LINES_SCALE = 0.5


def display_keeping_drawing(drawn: np.ndarray, base: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Like ``display_buffer(drawn, size)``, but the pixels where ``drawn`` differs from ``base`` (what was
    drawn on it: outlines, names) stay visible however far the picture is scaled down: each display pixel
    that covers any of them takes their mean colour, instead of the background's average. For a drawing on
    a picture of the same height and width; anything else is scaled as ``display_buffer`` does."""
    width, height = size
    picture = displayable(drawn)
    if base.shape[:2] != picture.shape[:2] or width >= picture.shape[1] * THIN_LINES_SCALE or picture.ndim != 3:
        return display_buffer(picture, size)
    plain = displayable(base)
    if plain.ndim == 2:
        plain = cv2.cvtColor(plain, cv2.COLOR_GRAY2BGR)
    marked = np.any(picture != plain, axis=2)
    small = cv2.resize(picture, (width, height), interpolation=cv2.INTER_AREA)
    if not marked.any():
        return cv2.cvtColor(small, cv2.COLOR_BGR2BGRA)
    # the share of each display pixel that is drawing, and the drawing's colour averaged over that share
    cover = cv2.resize(marked.view(np.uint8) * np.uint8(255), (width, height), interpolation=cv2.INTER_AREA)
    ink = cv2.resize(np.where(marked[:, :, None], picture, np.uint8(0)), (width, height),
                     interpolation=cv2.INTER_AREA)
    touched = cover > 0
    share = cover[touched].astype(np.float32)[:, None] / 255.0
    small[touched] = np.clip(ink[touched].astype(np.float32) / share, 0, 255).astype(np.uint8)
    return cv2.cvtColor(small, cv2.COLOR_BGR2BGRA)


def bgrx_qimage(bgrx: np.ndarray) -> ImageBuffer:
    """Wrap a ``display_buffer`` result without copying."""
    height, width = bgrx.shape[:2]
    return ImageBuffer(bgrx, QImage(bgrx.data, width, height, bgrx.strides[0], QImage.Format.Format_RGB32))


#: Whether display buffers can be used (Format_RGB32 is BGRX in memory only on little-endian machines).
FAST_DISPLAY = sys.byteorder == "little"


def rgb_qimage(rgb: np.ndarray) -> ImageBuffer:
    """Wrap an H x W x 3 RGB array (the 3D renderer's output) without copying."""
    array = np.ascontiguousarray(rgb, dtype=np.uint8)
    height, width = array.shape[:2]
    return ImageBuffer(array, QImage(array.data, width, height, array.strides[0], QImage.Format.Format_RGB888))


def describe_pixel(image: np.ndarray, x: int, y: int) -> str:
    """The pixel's values as a user picking HSV ranges wants them: BGR and OpenCV HSV, or a mask value."""
    if not (0 <= y < image.shape[0] and 0 <= x < image.shape[1]):
        return ""
    value = image[y, x]
    if image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 1):
        return f"value {int(np.asarray(value).ravel()[0])}"
    b, g, r = (int(c) for c in np.asarray(value).ravel()[:3])
    if image.dtype != np.uint8:
        return f"BGR ({b}, {g}, {r})"
    h, s, v = cv2.cvtColor(np.array([[[b, g, r]]], dtype=np.uint8), cv2.COLOR_BGR2HSV)[0, 0]
    return f"BGR ({b}, {g}, {r})  HSV ({int(h)}, {int(s)}, {int(v)})"
