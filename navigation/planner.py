"""Global path planning on the map: A* over an inflated costmap, then shortcutting.

Like move_base's global planner, obstacles are inflated by the robot's radius plus a margin (lethal),
and cells near that zone cost more, so paths keep to the middle of corridors instead of grazing walls.
Everything that depends only on the map (distance field, costs, connected regions, allowed moves and,
on big maps, landmark distances for the ALT heuristic) is computed once, which keeps a plan across the
Willow Garage map well under 100 ms in plain Python. Per-cell tables share their values' objects and the
landmarks are budgeted by map size, so a huge map costs tens of bytes and a few microseconds a cell to set up,
and a search that cannot finish within ``max_expansions`` ends as a failed plan: planning ends in bounded time
whatever the map.
"""

from __future__ import annotations

import heapq
import logging
import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from .costmap import ObstacleField, shared_list
from .geometry import Pose2D
from .grid_distance import distance_to_zero
from .passages import narrowest_passage

log = logging.getLogger(__name__)

SQRT2 = math.sqrt(2.0)
INF = math.inf


@dataclass(frozen=True)
class PlannerParams:
    """Inflation and cost shape; the defaults suit a TurtleBot 2 (radius 0.18 m)."""

    robot_radius: float = 0.18
    # Lethal zone = radius + margin from any obstacle; the margin absorbs path-following error.
    inflation_margin: float = 0.10
    # Beyond the lethal zone a cell costs 1 + cost_scale * exp(-(clearance - inflation) / cost_decay),
    # like the costmap's inflation layer: paths prefer the middle of a corridor.
    cost_scale: float = 2.0
    cost_decay: float = 0.15
    # Shortcut the grid path with straight lines no closer to obstacles than the part they replace
    # (or at least ``comfort`` m beyond the inflation, which is clear enough).
    smooth: bool = True
    comfort: float = 0.25
    # >1 trades a bounded amount of path cost for far fewer expansions (weighted A*); on the Willow map
    # 1.5 expands a third fewer cells than 1.0 for the same path length after shortcutting.
    heuristic_weight: float = 1.5
    # Landmark heuristic (ALT): exact costs from a few far-apart cells, computed once per map, bound the
    # cost-to-go from below far better than the straight line when the way leads round a building.
    # Only worth its set-up time (about 0.1 s per landmark on Willow) on maps with big free regions.
    landmarks: int = 6
    landmark_min_cells: int = 40_000
    # Landmarks x map cells at most: each landmark is a search over its region and a table over the map, so
    # a huge map gets fewer (none beyond half this many cells) and its set-up stays within a few seconds.
    landmark_budget: int = 3_000_000
    # A search that expands this many cells without reaching the goal gives up (a failed plan, not a hang);
    # a plan across Willow expands about a thousand.
    max_expansions: int = 1_000_000
    # Cells of the map (its shape, row 0 at the bottom) the planner must never enter, like Nav2's keepout filter;
    # they are inflated as obstacles are, so no part of the robot enters them. The simulator and the laser do
    # not see them: only the plan keeps out. See :mod:`navigation.costmap_filters`.
    keepout: np.ndarray | None = field(default=None, compare=False, repr=False)


@dataclass
class Plan:
    """The outcome of one planning request; ``path`` holds world (x, y) points from start to goal."""

    ok: bool
    path: np.ndarray
    reason: str = ""
    expansions: int = 0
    seconds: float = 0.0

    @property
    def length(self) -> float:
        if len(self.path) < 2:
            return 0.0
        return float(np.sum(np.hypot(*np.diff(self.path, axis=0).T)))


class Planner:
    """A* on the inflated costmap of one map; build it once and call :meth:`plan` many times."""

    def __init__(self, field: ObstacleField, params: PlannerParams | None = None) -> None:
        self.field = field
        self.params = params or PlannerParams()
        p = self.params
        self.inflation = p.robot_radius + p.inflation_margin
        self.keepout = self._padded_keepout(field, p.keepout)
        dist = field.dist
        if self.keepout is not None:  # keepout cells count as obstacles for the plan (and only for the plan)
            free = (~(field.obstacle | self.keepout)).astype(np.uint8)
            dist = distance_to_zero(free)
            dist *= field.resolution
        # Clearance of a cell = distance to the nearest obstacle surface (centre distance - half a cell).
        self.clear = dist - 0.5 * field.resolution
        del dist
        lethal = self.clear < self.inflation
        self.lethal = lethal
        cost = 1.0 + p.cost_scale * np.exp(-(self.clear - self.inflation) / max(p.cost_decay, 1e-6))
        cost[lethal] = INF
        self._cost = shared_list(cost)  # the search's hot tables are lists; the rest stay arrays
        del cost
        self._clear = self.clear.ravel()
        # Diagonal moves never cut a lethal corner, so 4-connected regions are exactly the reachable sets.
        _, labels = cv2.connectedComponents((~lethal).astype(np.uint8), connectivity=4)
        self.labels = labels
        self._labels = labels.ravel()
        self._gscore = [INF] * len(self._cost)
        self._build_moves(~lethal)
        w, h = field.width, field.height
        self._col = list(range(w)) * h  # one int object per column and per row, shared by every cell
        self._row = [j for j in range(h) for _ in range(w)]
        self._landmarks = self._build_landmarks()

    @staticmethod
    def _padded_keepout(field: ObstacleField, keepout: np.ndarray | None) -> np.ndarray | None:
        """The keepout cells on the field's padded grid, or None when there are none."""
        if keepout is None:
            return None
        keepout = np.asarray(keepout, dtype=bool)
        if keepout.shape != field.map.data.shape:
            raise ValueError(f"keepout cells of shape {keepout.shape} do not match the map's {field.map.data.shape}")
        if not keepout.any():
            return None
        padded = np.zeros_like(field.obstacle)
        padded[1:-1, 1:-1] = keepout
        return padded

    def _dijkstra(self, source: int) -> list[float]:
        """Exact path cost from ``source`` to every cell (INF where unreachable)."""
        cost, mask, moves = self._cost, self._mask, self._moves
        dist = [INF] * len(cost)
        dist[source] = 0.0
        heap = [(0.0, source)]
        pop, push = heapq.heappop, heapq.heappush
        while heap:
            du, u = pop(heap)
            if du > dist[u]:
                continue
            cu = cost[u]
            for d, factor in moves[mask[u]]:
                v = u + d
                nd = du + factor * (cu + cost[v])
                if nd < dist[v]:
                    dist[v] = nd
                    push(heap, (nd, v))
        return dist

    def _build_landmarks(self) -> list[list[float]]:
        """Landmarks for the largest free region, each the cell farthest (by path) from the previous ones."""
        p = self.params
        counts = np.bincount(self.labels.ravel())
        counts[0] = 0
        wanted = min(p.landmarks, p.landmark_budget // max(1, self.labels.size))
        if wanted < 2 or counts.max() < p.landmark_min_cells:
            if p.landmarks > 0 and wanted < 2 and counts.max() >= p.landmark_min_cells:
                log.info("%d cells: too big a map for landmarks (budget %d); plain A*", self.labels.size,
                         p.landmark_budget)
            return []
        t0 = time.perf_counter()
        region = self.labels.ravel() == counts.argmax()
        cells = np.flatnonzero(region)
        cols, rows = cells % self.field.width, cells // self.field.width
        # The first landmark: the region's cell farthest from its centroid, a corner of the building.
        nearest = np.full(len(cells), np.inf)
        nearest_idx = int(np.argmax(np.hypot(cols - cols.mean(), rows - rows.mean())))
        landmarks = []
        for _ in range(wanted):
            dist = self._dijkstra(int(cells[nearest_idx]))
            landmarks.append(dist)
            nearest = np.minimum(nearest, np.asarray(dist)[cells])
            nearest_idx = int(np.argmax(nearest))
        log.debug("%d landmarks over %d cells in %.2f s", len(landmarks), len(cells), time.perf_counter() - t0)
        return landmarks

    def _build_moves(self, passable: np.ndarray) -> None:
        """Per cell, a bit mask of the allowed steps, and per mask the (offset, cost factor) list.

        Done once with NumPy so the search loop never tests neighbours it may not enter, nor the two
        cells beside a diagonal step (which must both be free: no clipping of lethal corners).
        """
        w = self.field.width
        steps = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1)]
        padded = np.zeros((passable.shape[0] + 2, passable.shape[1] + 2), dtype=bool)
        padded[1:-1, 1:-1] = passable

        def shifted(dx: int, dy: int) -> np.ndarray:
            return padded[1 + dy:padded.shape[0] - 1 + dy, 1 + dx:padded.shape[1] - 1 + dx]

        mask = np.zeros(passable.shape, dtype=np.int64)
        for bit, (dx, dy) in enumerate(steps):
            ok = passable & shifted(dx, dy)
            if dx and dy:
                ok &= shifted(dx, 0) & shifted(0, dy)
            mask |= ok.astype(np.int64) << bit
        self._mask = mask.ravel().tolist()
        self._moves = [tuple((dx + dy * w, 0.5 * SQRT2 if dx and dy else 0.5)
                             for bit, (dx, dy) in enumerate(steps) if m >> bit & 1) for m in range(256)]

    # -- cell helpers -------------------------------------------------------------------------------
    def _index(self, x: float, y: float) -> int | None:
        i, j = self.field.cell(x, y)
        if not self.field.inside(i, j):
            return None
        return j * self.field.width + i

    def _to_world(self, idx: int) -> tuple[float, float]:
        j, i = divmod(idx, self.field.width)
        return self.field.map.cell_to_world(i - 1, j - 1)

    def _escape(self, idx: int) -> list[int] | None:
        """Climb the distance field out of the inflated zone (a start pressed against a wall)."""
        w, clear, radius = self.field.width, self._clear, self.params.robot_radius
        if clear[idx] < radius - 0.5 * self.field.resolution:
            return None
        chain = [idx]
        for _ in range(int(self.inflation / self.field.resolution) + 3):
            if self._cost[chain[-1]] < INF:
                return chain
            cur = chain[-1]
            best = max((cur + d for d in (1, -1, w, -w, w + 1, w - 1, -w + 1, -w - 1)), key=lambda n: clear[n])
            if clear[best] <= clear[cur]:
                return None
            chain.append(best)
        return chain if self._cost[chain[-1]] < INF else None

    def _goal_cell(self, idx: int, x: float, y: float, tolerance: float, label: int | None) -> int | None:
        """The goal cell, or the nearest free cell within ``tolerance`` when the goal is inflated.

        With ``label`` the cell must lie in that connected region; ``None`` accepts any region.
        """
        if self._cost[idx] < INF and label in (None, self._labels[idx]):
            return idx
        w, res = self.field.width, self.field.resolution
        j, i = divmod(idx, w)
        reach = math.ceil(tolerance / res)
        best, best_d = None, INF
        for dj in range(-reach, reach + 1):
            for di in range(-reach, reach + 1):
                ni, nj = i + di, j + dj
                if not self.field.inside(ni, nj):
                    continue
                n = nj * w + ni
                if self._cost[n] == INF or label not in (None, self._labels[n]):
                    continue
                cx, cy = self._to_world(n)
                d = math.hypot(cx - x, cy - y)
                if d <= tolerance and d < best_d:
                    best, best_d = n, d
        return best

    def _in_keepout(self, idx: int) -> bool:
        """Whether a cell is in (or, inflated, too near) a keepout zone rather than a real obstacle."""
        if self.keepout is None:
            return False
        return bool(self.field.dist.ravel()[idx] - 0.5 * self.field.resolution >= self.params.robot_radius)

    def explain_no_path(self, start: int, goal: int) -> str:
        """Why two free cells of different regions are not connected: the narrowest passage and the inflation
        that closed it (see :mod:`navigation.passages`)."""
        passage = narrowest_passage(self.clear, start, goal)
        if passage is None:
            return "the goal lies in a region the start cannot reach"  # walled off: inflation is not why
        j, i = divmod(passage.cell, self.field.width)
        x, y = self.field.map.cell_to_world(i - 1, j - 1)
        p = self.params
        text = (f"the goal lies in a region the start cannot reach: the narrowest passage on the way, near "
                f"({x:.2f}, {y:.2f}), is about {passage.width(self.field.resolution):.2f} m wide and leaves "
                f"{passage.clearance:.3f} m each side of the robot's centre; planning keeps {self.inflation:.3f} m "
                f"(robot radius {p.robot_radius:g} + inflation margin {p.inflation_margin:g})")
        opening = math.floor((passage.clearance - p.robot_radius) * 100 + 1e-6) / 100  # whole centimetres
        if opening >= 0.0:
            return f"{text}: an inflation margin of {opening:.2f} m or less opens it"
        return f"{text}: narrower than the robot itself, no inflation margin opens it"

    # -- search -------------------------------------------------------------------------------------
    def _astar(self, start: int, goal: int) -> tuple[list[int] | None, int]:
        """8-connected A* with the octile heuristic; diagonal steps may not clip a lethal corner. None after
        ``max_expansions`` cells without reaching the goal.

        Written with flat lists, precomputed moves and local names: this loop is where planning time goes.
        """
        cost, mask, moves, col, row = self._cost, self._mask, self._moves, self._col, self._row
        gscore = self._gscore
        closed = bytearray(len(cost))
        touched = [start]
        came: dict[int, int] = {start: -1}
        gscore[start] = 0.0
        gi, gj = col[goal], row[goal]
        heap = [(0.0, start)]
        pop, push = heapq.heappop, heapq.heappush
        hw = self.params.heuristic_weight
        k_diag = SQRT2 - 2.0
        alt = [(lm, lm[goal]) for lm in self._landmarks if lm[goal] < INF and lm[start] < INF]
        expansions = 0
        budget = self.params.max_expansions
        try:
            while heap:
                u = pop(heap)[1]
                if closed[u]:
                    continue
                if u == goal:
                    path = [u]
                    while came[path[-1]] >= 0:
                        path.append(came[path[-1]])
                    return path[::-1], expansions
                closed[u] = 1
                expansions += 1
                if expansions > budget:
                    return None, expansions
                gu, cu = gscore[u], cost[u]
                for d, factor in moves[mask[u]]:
                    v = u + d
                    if closed[v]:
                        continue
                    ng = gu + factor * (cu + cost[v])
                    if ng < gscore[v]:
                        if gscore[v] == INF:
                            touched.append(v)
                        gscore[v] = ng
                        came[v] = u
                        dx = col[v] - gi
                        if dx < 0:
                            dx = -dx
                        dy = row[v] - gj
                        if dy < 0:
                            dy = -dy
                        h = dx + dy + k_diag * (dx if dx < dy else dy)
                        for lm, lm_goal in alt:  # |d(L, v) - d(L, goal)| <= d(v, goal)
                            x = lm[v] - lm_goal
                            if x < 0:
                                x = -x
                            if x > h:
                                h = x
                        push(heap, (ng + hw * h, v))
            return None, expansions
        finally:
            for t in touched:  # reset only what this search wrote; the list is reused
                gscore[t] = INF

    def _segment_clear(self, a: tuple[float, float], b: tuple[float, float], need: float) -> bool:
        """Whether every cell on the straight line a-b (padded-grid cell units) has ``need`` m clearance."""
        ax, ay = a
        n = max(2, int(math.hypot(b[0] - ax, b[1] - ay) * 2) + 2)
        sx, sy = (b[0] - ax) / (n - 1), (b[1] - ay) / (n - 1)
        clear, w = self._clear, self.field.width
        return all(clear[int(ay + k * sy) * w + int(ax + k * sx)] >= need for k in range(n))

    def _shortcut(self, cells: list[int]) -> list[int]:
        """Drop waypoints where a straight line is as clear as the grid path it replaces (or clear enough)."""
        if len(cells) < 3:
            return cells
        w = self.field.width
        pts = [(c % w + 0.5, c // w + 0.5) for c in cells]
        clears = [self._clear[c] for c in cells]
        comfort = self.inflation + self.params.comfort

        def ok(a: int, b: int) -> bool:
            return self._segment_clear(pts[a], pts[b], min(min(clears[a:b + 1]), comfort) - 1e-9)

        out = [0]
        a, last = 0, len(cells) - 1
        while a < last:
            good, step = a + 1, 1
            while good + step <= last and ok(a, good + step):
                good += step
                step *= 2
            lo, hi = good, min(good + step, last + 1)
            while hi - lo > 1:  # largest reachable index between the last success and the first failure
                mid = (lo + hi) // 2
                if ok(a, mid):
                    lo = mid
                else:
                    hi = mid
            out.append(lo)
            a = lo
        return [cells[k] for k in out]

    def plan(self, start: Pose2D, goal: Pose2D, goal_tolerance: float = 0.15) -> Plan:
        """A collision-free path from ``start`` to within ``goal_tolerance`` of ``goal``, or why not."""
        t0 = time.perf_counter()

        def fail(reason: str, expansions: int = 0) -> Plan:
            log.debug("no plan from %s to %s: %s", start, goal, reason)
            return Plan(False, np.empty((0, 2)), reason, expansions, time.perf_counter() - t0)

        s = self._index(start.x, start.y)
        if s is None:
            return fail("start is outside the map")
        escape = [s] if self._cost[s] < INF else self._escape(s)
        if escape is None:
            return fail("start is in a keepout zone" if self._in_keepout(s) else "start is in an obstacle")
        g = self._index(goal.x, goal.y)
        if g is None:
            return fail("goal is outside the map")
        label = int(self._labels[escape[-1]])
        g_cell = self._goal_cell(g, goal.x, goal.y, goal_tolerance, label)
        if g_cell is None:
            g_any = self._goal_cell(g, goal.x, goal.y, goal_tolerance, None)
            if g_any is None:
                return fail("goal is in a keepout zone" if self._in_keepout(g) else "goal is in an obstacle")
            return fail(f"no path: {self.explain_no_path(escape[-1], g_any)}")
        cells, expansions = self._astar(escape[-1], g_cell)
        if cells is None:
            if expansions > self.params.max_expansions:
                return fail(f"no path found within {self.params.max_expansions} expanded cells", expansions)
            return fail("no path", expansions)
        cells = escape[:-1] + cells
        if self.params.smooth:
            cells = self._shortcut(cells)
        pts = [self._to_world(c) for c in cells]
        pts[0] = (start.x, start.y)
        path = np.array(pts, dtype=np.float64)
        return Plan(True, path, "", expansions, time.perf_counter() - t0)
