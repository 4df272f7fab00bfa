"""Bases for image modules: they set the data kind and the message type, and hold the one colour
conversion that any filter/detector combination may need."""

from __future__ import annotations

from typing import ClassVar

import cv2
import numpy as np

from objrec_core import DetectedObjectArray, Detector, Filter

from .messages import DetectedObject2DArray


class ImageFilter(Filter):
    """A filter on OpenCV images (BGR ``uint8`` H x W x 3, or a single-channel mask)."""

    kind = "2d"


class ImageDetector(Detector):
    """A detector on OpenCV images; reports ``DetectedObject2DArray``."""

    kind = "2d"
    object_array_type: ClassVar[type[DetectedObjectArray]] = DetectedObject2DArray


_UINT8 = np.dtype(np.uint8)


def as_gray(image: np.ndarray) -> np.ndarray:
    """A single-channel 8-bit view of any image: masks pass through untouched, colour is converted once,
    boolean or float masks from a plug-in filter become 0/255."""
    if image.dtype is not _UINT8 and image.dtype != np.uint8:  # the identity first: a third of the comparison's time
        if image.dtype == np.bool_ or image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 1):
            image = np.where(image.reshape(image.shape[:2]) > 0, np.uint8(255), np.uint8(0))
        else:
            image = cv2.convertScaleAbs(image)
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 1:
        return image[:, :, 0]
    if image.ndim == 3 and image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2GRAY)
    if image.ndim == 3 and image.shape[2] == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    raise ValueError(f"expected an image (H x W or H x W x 1/3/4), got an array of shape {image.shape}")


def as_bgr(image: np.ndarray) -> np.ndarray:
    """A three-channel BGR view of any image (a mask becomes grey)."""
    if image.ndim == 3 and image.shape[2] == 3:
        return image
    if image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 1):
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if image.ndim == 3 and image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    raise ValueError(f"expected an image (H x W or H x W x 1/3/4), got an array of shape {image.shape}")
