"""The one point-cloud type of the 3D library.

``PointCloud`` is deliberately plain: two NumPy arrays and a layout, so filters, detectors, the annotation
code and the definition GUI all read the same attributes without conversion:

- ``points``: ``float32`` array of shape (N, 3), C-contiguous, metres in the sensor frame (x right, y down,
  z forward for a depth camera). A row of NaN is an invalid point (no return, or removed by a filter).
- ``colors``: ``uint8`` array of shape (N, 3), RGB, or ``None``.
- ``width`` x ``height``: the layout. An *organized* cloud (``height > 1``, e.g. 640 x 480 from an RGB-D
  sensor) stores its points row by row as the image they came from, ``N == width * height``, exactly as
  PCL does; an unorganized cloud has ``height == 1`` and ``width == N``.

Filters keep an organized cloud organized: ``select(mask)`` marks the points it drops as NaN instead of
deleting them, so normals can still be computed from image neighbours. Open3D is imported only by
``to_open3d``/``from_open3d``, which keeps ``import objrec3d`` quick.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    import open3d


class PointCloud:
    """Points (float32 N x 3), optional colours (uint8 N x 3 RGB) and the width x height layout."""

    __slots__ = ("colors", "height", "points", "sensor_origin", "width")

    def __init__(
        self,
        points: Any,
        colors: Any | None = None,
        width: int | None = None,
        height: int | None = None,
        *,
        sensor_origin: Any = (0.0, 0.0, 0.0),
    ) -> None:
        pts = np.asarray(points)
        if pts.ndim == 3 and pts.shape[2] == 3:  # an H x W x 3 grid
            if height is None and width is None:
                height, width = pts.shape[:2]
            pts = pts.reshape(-1, 3)
        if pts.size == 0:
            pts = pts.reshape(0, 3)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must be an N x 3 (or H x W x 3) array, got shape {pts.shape}")
        if not np.issubdtype(pts.dtype, np.number):
            raise ValueError(f"points must be numbers, got dtype {pts.dtype}")
        n = pts.shape[0]
        self.points: np.ndarray = np.ascontiguousarray(pts, dtype=np.float32)
        if width is None and height is None:
            width, height = n, 1
        elif width is None:
            width = n // height if height else 0
        elif height is None:
            height = n // width if width else 0
        if width * height != n:
            raise ValueError(f"a {width} x {height} layout needs {width * height} points, got {n}")
        self.width = int(width)
        self.height = int(height)
        self.colors: np.ndarray | None = None if colors is None else _as_colors(colors, n)
        self.sensor_origin = np.asarray(sensor_origin, dtype=np.float64).reshape(3)

    # -- construction -------------------------------------------------------------------------------
    @classmethod
    def from_numpy(cls, points: Any, colors: Any | None = None, **layout: Any) -> PointCloud:
        """From an N x 3 (unorganized) or H x W x 3 (organized) array; colours uint8 RGB or float 0..1."""
        return cls(points, colors, **layout)

    @classmethod
    def from_open3d(cls, cloud: open3d.geometry.PointCloud, width: int | None = None, height: int | None = None
                    ) -> PointCloud:
        """From an Open3D cloud; give ``width``/``height`` when it still holds an organized grid (Open3D
        itself keeps no layout)."""
        points = np.asarray(cloud.points)
        colors = np.asarray(cloud.colors) if cloud.has_colors() else None
        return cls(points, colors, width, height)

    @classmethod
    def empty(cls) -> PointCloud:
        return cls(np.empty((0, 3), np.float32))

    def to_open3d(self, keep_invalid: bool = False) -> open3d.geometry.PointCloud:
        """An Open3D cloud (float64, colours 0..1). Invalid points are dropped unless ``keep_invalid``."""
        import open3d as o3d

        mask = slice(None) if keep_invalid else self.valid_mask()
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(self.points[mask].astype(np.float64)))
        if self.colors is not None:
            cloud.colors = o3d.utility.Vector3dVector(self.colors[mask].astype(np.float64) / 255.0)
        return cloud

    def copy(self) -> PointCloud:
        return PointCloud(self.points.copy(), None if self.colors is None else self.colors.copy(),
                          self.width, self.height, sensor_origin=self.sensor_origin.copy())

    # -- layout -------------------------------------------------------------------------------------
    def __len__(self) -> int:
        return self.points.shape[0]

    @property
    def is_organized(self) -> bool:
        """True for an image-like layout (height > 1): neighbours in the grid are neighbours in space."""
        return self.height > 1

    def grid(self, values: np.ndarray | None = None) -> np.ndarray:
        """``values`` (default: the points), one row per point, viewed as height x width x ...; organized only."""
        if not self.is_organized:
            raise ValueError("an unorganized cloud has no image grid")
        values = self.points if values is None else values
        return values.reshape(self.height, self.width, *values.shape[1:])

    def valid_mask(self) -> np.ndarray:
        """Boolean mask of points whose three coordinates are finite."""
        # One sum and one test instead of three tests and a reduction: a NaN or infinite coordinate makes
        # the sum non-finite (so does an absurd 1e38 m, which is no measurement either).
        p = self.points
        with np.errstate(invalid="ignore", over="ignore"):  # inf + -inf, 3e38 + 3e38: invalid, and no warning
            return np.isfinite(p[:, 0] + p[:, 1] + p[:, 2])

    def count_valid(self) -> int:
        return int(np.count_nonzero(self.valid_mask()))

    # -- selection ----------------------------------------------------------------------------------
    def select(self, keep: np.ndarray) -> PointCloud:
        """The points where ``keep`` is true (a boolean mask over all N points).

        An organized cloud stays organized: dropped points become NaN. An unorganized one shrinks.
        """
        keep = np.asarray(keep, dtype=bool).reshape(-1)
        if keep.shape[0] != len(self):
            raise ValueError(f"mask has {keep.shape[0]} entries for {len(self)} points")
        if self.is_organized:
            # Adding NaN to the dropped rows (0 to the rest) is a third faster than np.where over the rows.
            points = self.points + np.where(keep, np.float32(0.0), np.float32(np.nan))[:, None]
            return PointCloud(points, self.colors, self.width, self.height, sensor_origin=self.sensor_origin)
        colors = None if self.colors is None else self.colors[keep]
        return PointCloud(self.points[keep], colors, sensor_origin=self.sensor_origin)

    def compacted(self) -> PointCloud:
        """The valid points only, unorganized."""
        keep = self.valid_mask()
        colors = None if self.colors is None else self.colors[keep]
        return PointCloud(self.points[keep], colors, sensor_origin=self.sensor_origin)

    def __repr__(self) -> str:
        layout = f"{self.width}x{self.height} organized" if self.is_organized else "unorganized"
        colour = ", coloured" if self.colors is not None else ""
        return f"PointCloud({len(self)} points, {self.count_valid()} valid, {layout}{colour})"


def _as_colors(colors: Any, n: int) -> np.ndarray:
    c = np.asarray(colors)
    if c.ndim == 3:
        c = c.reshape(-1, c.shape[-1])
    if c.ndim != 2 or c.shape[0] != n or c.shape[1] not in (3, 4):
        raise ValueError(f"colors must be N x 3 for {n} points, got shape {c.shape}")
    c = c[:, :3]
    if np.issubdtype(c.dtype, np.floating):
        c = np.clip(np.nan_to_num(c) * 255.0 + 0.5, 0, 255)
    return np.ascontiguousarray(c, dtype=np.uint8)


def as_cloud(data: Any) -> PointCloud:
    """Accept what a user may hand a module from a script: a PointCloud, an N x 3 / H x W x 3 array, or an
    Open3D cloud."""
    if isinstance(data, PointCloud):
        return data
    if hasattr(data, "points") and hasattr(data, "has_colors"):
        return PointCloud.from_open3d(data)
    if isinstance(data, np.ndarray | list | tuple):
        return PointCloud(data)
    raise TypeError(f"expected a PointCloud, an N x 3 array or an Open3D cloud, got {type(data).__name__}")
