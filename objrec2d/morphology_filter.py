"""MorphologyFilter: erosion, dilation, opening or closing, to clean a mask before detection."""

from __future__ import annotations

from typing import ClassVar

import cv2
import numpy as np

from objrec_core import Choice, Int

from .base import ImageFilter


class MorphologyFilter(ImageFilter):
    """One morphological operation, repeated ``iterations`` times with one structuring element.

    Opening removes specks smaller than the kernel; closing fills holes. Works on masks and colour images.
    """

    OPERATIONS: ClassVar[dict[str, int]] = {
        "erode": cv2.MORPH_ERODE,
        "dilate": cv2.MORPH_DILATE,
        "open": cv2.MORPH_OPEN,
        "close": cv2.MORPH_CLOSE,
    }
    SHAPES: ClassVar[dict[str, int]] = {
        "rect": cv2.MORPH_RECT,
        "ellipse": cv2.MORPH_ELLIPSE,
        "cross": cv2.MORPH_CROSS,
    }

    operation = Choice("open", list(OPERATIONS), "open removes specks, close fills holes")
    iterations = Int(1, "How often the operation is applied; 0 passes the image through", min=0, max=20)
    kernel_size = Int(3, "Side of the structuring element in pixels (odd)", min=1, max=31, step=2)
    kernel_shape = Choice("rect", list(SHAPES), "Shape of the structuring element")

    def __init__(self, id: str | None = None, **parameters: object) -> None:
        self._kernel: tuple[int, str, np.ndarray] | None = None
        super().__init__(id, **parameters)

    def _kernel_for(self, size: int, shape: str) -> np.ndarray:
        """The structuring element for this frame's snapshot, cached with the values it was made for, so a
        change from another thread can never leave a kernel of the wrong shape in use."""
        cached = self._kernel
        if cached is not None and cached[0] == size and cached[1] == shape:
            return cached[2]
        kernel = cv2.getStructuringElement(self.SHAPES[shape], (size, size))
        self._kernel = (size, shape, kernel)
        return kernel

    def filter(self, frame: np.ndarray) -> np.ndarray:
        p = self.params
        if p.iterations == 0:
            return frame
        kernel = self._kernel_for(p.kernel_size, p.kernel_shape)
        return cv2.morphologyEx(frame, self.OPERATIONS[p.operation], kernel, iterations=p.iterations)
