"""What the laser shows in the robot's way that the map does not: move_base's obstacle layer.

The global planner knows only the map. Like the obstacle layer of move_base's costmaps, this layer marks
the cells where laser beams end and clears the cells that beams pass through, so something put in the
robot's way since the map was made (a box, a person, a closed door) is seen, planned round, and forgotten
again once the laser sees through the place where it was. Returns that fall on the map's own obstacles are
left out: the planner already keeps clear of those, and an empty layer costs nothing in a known world.

The layer's cells are the map's own grid cells (those of the planner's :class:`ObstacleField`), so it can
be handed to the planner as extra obstacles (:meth:`LocalCostmap.as_map`). Marks persist, as in the
global costmap, until a beam clears them or a recovery behaviour clears the layer; the controller looks
for them only in a window around the robot (the local costmap's extent), see :meth:`LocalCostmap.blocking`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .costmap import ObstacleField
from .geometry import Pose2D
from .laser import LaserScan
from .maps import FREE, OCCUPIED, OccupancyMap


@dataclass(frozen=True)
class LocalCostmapParams:
    """Marking, clearing and update-rate settings; ranges follow the TurtleBot's costmap parameters.

    A scan costs as much as dozens of simulation steps, so the laser is read when the robot has moved or
    turned enough to see something new (``update_distance`` metres, ``update_angle`` radians, a little
    less than the 58 degree field of view) or ``update_period`` seconds have passed. While the robot
    watches a blocked way, and for ``update_period`` seconds after a scan found that something seen before
    has gone (it moves), every one of these is divided by ``fast_rate``, to follow what moves closely.
    ``beams`` is how many beams to ask the laser for (at most): 160 over 58 degrees are 1.6 cm apart at
    the 2.5 m marking range, several to every 5 cm cell, for a quarter of the cost of the full 640.
    ``keep_near``: while the robot waits (:meth:`LocalCostmap.refresh`), marks out of view are forgotten except
    within this distance of it, where someone standing beside the robot would be.
    """

    window: float = 4.0
    obstacle_range: float = 2.5
    raytrace_range: float = 3.0
    mapped_tolerance: float = 0.15
    update_distance: float = 1.0
    update_angle: float = 0.9
    update_period: float = 3.0
    fast_rate: float = 4.0
    beams: int = 160
    keep_near: float = 1.0


class LocalCostmap:
    """Marked cells (flat indices into the planner field's padded grid) and the queries move_base needs."""

    def __init__(self, field: ObstacleField, params: LocalCostmapParams | None = None) -> None:
        self.field = field
        self.params = params or LocalCostmapParams()
        self._cells: set[int] = set()
        self._flat: np.ndarray | None = None  # the marked cells as an array, in the order of _points
        self._points: np.ndarray | None = None
        # Bumped whenever the marked set changes, so a planner built for one set can be reused.
        self.version = 0
        self.scans = 0
        self.monitor_scans = 0  # scans the controller's collision guard read while driving (see MoveBase)
        # What the last scan did: cells newly marked and cells cleared. Cleared cells mean that something
        # seen before is no longer there: it has moved, or been moved.
        self.last_marked = 0
        self.last_cleared = 0

    def __len__(self) -> int:
        return len(self._cells)

    @property
    def empty(self) -> bool:
        return not self._cells

    # -- geometry helpers -----------------------------------------------------------------------------
    def _cells_of(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Flat padded-grid indices of world points (-1 outside the grid)."""
        gx, gy = self.field.map.world_to_grid(x, y)
        i = np.floor(gx).astype(np.int64) + 1
        j = np.floor(gy).astype(np.int64) + 1
        inside = (i >= 0) & (i < self.field.width) & (j >= 0) & (j < self.field.height)
        return np.where(inside, j * self.field.width + i, -1)

    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The marked cells' flat indices and world centres, built once per change of the set."""
        if self._flat is None or self._points is None:
            flat = np.fromiter(self._cells, dtype=np.int64, count=len(self._cells))
            j, i = np.divmod(flat, self.field.width)
            x, y = self.field.map.grid_to_world(i - 1 + 0.5, j - 1 + 0.5)
            self._flat = flat
            self._points = np.column_stack([np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)])
        return self._flat, self._points

    def points(self) -> np.ndarray:
        """World (x, y) centres of the marked cells, shape (N, 2)."""
        return self._arrays()[1]

    def subset(self, keep: np.ndarray) -> LocalCostmap:
        """A new layer with only the marks where ``keep`` (in the order of :meth:`points`) is true: to ask what a
        plan round some of the marks would be, leaving this layer alone."""
        flat, _ = self._arrays()
        other = LocalCostmap(self.field, self.params)
        other._cells = set(flat[np.asarray(keep, dtype=bool)].tolist())
        return other

    def _changed(self) -> None:
        self._flat = self._points = None
        self.version += 1

    def near(self, x: float, y: float, reach: float) -> np.ndarray:
        """Marked cell centres within ``reach`` (Chebyshev distance) of (x, y)."""
        pts = self.points()
        if not len(pts):
            return pts
        keep = (np.abs(pts[:, 0] - x) <= reach) & (np.abs(pts[:, 1] - y) <= reach)
        return pts[keep]

    # -- sensing --------------------------------------------------------------------------------------
    def update(self, pose: Pose2D, scan: LaserScan, monitor: bool = False) -> bool:
        """Clear the cells the beams pass through, then mark where they end; True when the layer changed.

        ``pose`` is where the robot believes it was when the scan was taken (the pose move_base drives on),
        so the marks land where the planner will look for them. ``monitor``: a scan the collision guard read
        (counted in ``monitor_scans``, not ``scans``).
        """
        if monitor:
            self.monitor_scans += 1
        else:
            self.scans += 1
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        gone: set[int] = self._clear_seen(pose, scan, ranges) if self._cells else set()
        new = self._marked_by(pose, scan, ranges) - self._cells
        self._cells |= new
        # A cell cleared and marked again by the same scan (an edge seen from a new angle) has not changed.
        self.last_marked, self.last_cleared = len(new - gone), len(gone - new)
        changed = bool(self.last_marked or self.last_cleared)
        if changed:
            self._changed()
        return changed

    def refresh(self, pose: Pose2D, scan: LaserScan) -> bool:
        """Keep only what ``scan`` (taken at ``pose``) marks, and the marks within ``keep_near`` of the robot that
        no beam passed through; True when the layer changed.

        For a robot standing still to watch a blocked way. A mark farther out of the laser's view, or hidden
        behind what it sees now, is where a person was, not where one is known to be: a walker that went past
        the robot, out of its 58 degree view, or walked on behind another, leaves its trail there, and no beam
        will ever pass through it while the robot stands. A wait for a way round such marks waits for nobody.
        A person right beside the robot is out of its view too, and is no trail: those marks stay.
        Unlike :meth:`clear`, the layer (and its ``version``) changes only when a mark comes or goes.
        """
        self.scans += 1
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        old = set(self._cells)
        cells = self._marked_by(pose, scan, ranges) | self._unseen_near(pose, scan, ranges)
        new, gone = cells - old, old - cells
        self.last_marked, self.last_cleared = len(new), len(gone)
        self._cells = cells
        if not (new or gone):
            return False
        self._changed()
        return True

    def _unseen_near(self, pose: Pose2D, scan: LaserScan, ranges: np.ndarray) -> set[int]:
        """The marks within ``keep_near`` of ``pose`` that no beam of ``scan`` passed through (leaves the layer
        without the ones it did: the caller sets the layer anew)."""
        if not self._cells:
            return set()
        flat, pts = self._arrays()
        near = set(flat[np.hypot(pts[:, 0] - pose.x, pts[:, 1] - pose.y) <= self.params.keep_near].tolist())
        return near - self._clear_seen(pose, scan, ranges)

    def _marked_by(self, pose: Pose2D, scan: LaserScan, ranges: np.ndarray) -> set[int]:
        """The cells where the scan's returns within ``obstacle_range`` end, except those on the map's obstacles."""
        p = self.params
        hit = np.isfinite(ranges) & (ranges <= p.obstacle_range)
        if not hit.any():
            return set()
        angles = pose.yaw + scan.angle_min + scan.angle_increment * np.flatnonzero(hit)
        r = ranges[hit]
        cells = self._cells_of(pose.x + r * np.cos(angles), pose.y + r * np.sin(angles))
        cells = cells[cells >= 0]
        # A return on or next to one of the map's obstacles is the map's own (allowing for the pose error).
        unmapped = self.field.dist.ravel()[cells] > p.mapped_tolerance
        return set(cells[unmapped].tolist())

    def _clear_seen(self, pose: Pose2D, scan: LaserScan, ranges: np.ndarray) -> set[int]:
        """Drop marked cells whose centre a beam reached and passed (by at least one cell); returns them."""
        flat, pts = self._arrays()
        dx, dy = pts[:, 0] - pose.x, pts[:, 1] - pose.y
        dist = np.hypot(dx, dy)
        inc = scan.angle_increment
        bearing = np.arctan2(dy, dx) - pose.yaw
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        n = len(ranges)
        if inc > 0:
            beam = np.rint((bearing - scan.angle_min) / inc).astype(np.int64)
        else:
            beam = np.where(np.abs(bearing - scan.angle_min) < 1e-3, 0, -1)
        # A short scan (the controller's guard) clears only as far as it reaches.
        seen = (beam >= 0) & (beam < n) & (dist <= min(self.params.raytrace_range, scan.range_max))
        if not seen.any():
            return set()
        through = np.zeros(len(pts), dtype=bool)
        through[seen] = ranges[beam[seen]] > dist[seen] + self.field.resolution
        gone = set(flat[through].tolist())
        self._cells -= gone
        return gone

    def clear(self, pose: Pose2D | None = None, scan: LaserScan | None = None) -> int:
        """The clear-costmap recovery: wipe every mark, then mark again what the current ``scan`` (taken at
        ``pose``) shows; returns how many marks were wiped.

        This is what clearing does on a robot, whose next sensor update re-marks what is still in view; here
        that update is part of the clear, so an obstacle still in view (a walker standing in the way) survives
        it and is not re-planned through. Without a scan every mark goes.
        """
        wiped = len(self._cells)
        if not wiped:
            return 0
        self._cells.clear()
        self._changed()
        if pose is not None and scan is not None:
            self.update(pose, scan)
        return wiped

    # -- queries for the controller and the planner ---------------------------------------------------
    def distance(self, x: np.ndarray, y: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """For each point, the distance to the nearest of ``cells`` (centres) as an obstacle surface."""
        if not len(cells):
            return np.full(np.shape(x), math.inf)
        d = np.hypot(np.subtract.outer(np.asarray(x), cells[:, 0]), np.subtract.outer(np.asarray(y), cells[:, 1]))
        return d.min(axis=-1) - 0.5 * self.field.resolution

    def blocking(self, path: np.ndarray, clearance: float, reach: float | None = None
                 ) -> tuple[float, float, float] | None:
        """The first point of ``path`` closer than ``clearance`` to a marked cell: (x, y, path distance).

        ``path`` starts where the robot is; with ``reach`` only its first part within ``reach`` metres
        (Chebyshev) of that start is checked: the local costmap's window. A robot already closer than
        ``clearance`` to something is not blocked by a path that leads away from it: only points closer
        than the start count then. ``None`` when the way is free.
        """
        if not self._cells or len(path) == 0:
            return None
        samples, along = _densify(np.asarray(path, dtype=np.float64), self.field.resolution)
        x0, y0 = samples[0]
        if reach is not None:
            inside = (np.abs(samples[:, 0] - x0) <= reach) & (np.abs(samples[:, 1] - y0) <= reach)
            stop = len(samples) if inside.all() else int(np.argmin(inside))
            samples, along = samples[:stop], along[:stop]
        if not len(samples):
            return None
        lo, hi = samples.min(axis=0) - clearance - self.field.resolution, samples.max(axis=0) + clearance + 1.0
        pts = self.points()
        box = (pts[:, 0] >= lo[0]) & (pts[:, 0] <= hi[0]) & (pts[:, 1] >= lo[1]) & (pts[:, 1] <= hi[1])
        cells = pts[box]
        if not len(cells):
            return None
        limit = min(clearance, float(self.distance(samples[:1, 0], samples[:1, 1], cells)[0]) - 1e-6)
        for k in range(0, len(samples), 256):  # chunks bound the size of the distance matrix
            chunk = samples[k:k + 256]
            d = self.distance(chunk[:, 0], chunk[:, 1], cells)
            bad = np.flatnonzero(d < limit)
            if len(bad):
                b = k + int(bad[0])
                return float(samples[b, 0]), float(samples[b, 1]), float(along[b])
        return None

    def disc_free(self, x: float, y: float, radius: float) -> bool:
        """Whether a disc of ``radius`` at (x, y) keeps clear of every marked cell."""
        cells = self.near(x, y, radius + self.field.resolution)
        return not len(cells) or float(self.distance(np.array([x]), np.array([y]), cells)[0]) >= radius

    def as_map(self) -> OccupancyMap:
        """The planner's obstacles plus the marked cells, as a map the planner can be built on."""
        obstacle = self.field.obstacle.copy()
        if self._cells:
            flat = np.fromiter(self._cells, dtype=np.int64, count=len(self._cells))
            obstacle.ravel()[flat] = True
        data = np.where(obstacle[1:-1, 1:-1], OCCUPIED, FREE).astype(np.int8)
        m = self.field.map
        return OccupancyMap(data, m.resolution, m.origin, m.source)


def _densify(path: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along a polyline no farther than ``step`` apart, and their distance along it."""
    if len(path) == 1:
        return path.copy(), np.zeros(1)
    seg = np.diff(path, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    starts = np.concatenate([[0.0], np.cumsum(lengths)])
    pieces, along = [], []
    for k, length in enumerate(lengths):
        n = max(1, math.ceil(length / step))
        t = np.arange(n) / n
        pieces.append(path[k] + np.outer(t, seg[k]))
        along.append(starts[k] + t * length)
    pieces.append(path[-1:])
    along.append(starts[-1:])
    return np.concatenate(pieces), np.concatenate(along)
