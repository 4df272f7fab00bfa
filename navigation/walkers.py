"""Moving obstacles as bodies: walkers that stop for the robot or step aside, never through it.

A world file's moving obstacle goes back and forth along its segment. Scripted as a pure function of time
it would walk straight through a robot standing in its way; a person does not. Each walker here keeps its
own state (how far along its back-and-forth it is, how far it has stepped off its line) and reacts to the
robot with the simplest model that keeps bodies apart, chosen per obstacle with ``avoid`` in the world file:

- ``stop`` (the default): it waits while the robot stands in its way and, after :data:`PATIENCE` seconds
  of waiting, turns back, as a person meeting a robot in a corridor does;
- ``sidestep``: a one-dimensional social force: it steps off its line, to the side away from the robot and
  only as far as the walls allow, passes, and returns to its line; where there is no room it stops;
- ``none``: the scripted walker of old, blind to the robot (for experiments: its overlaps are collisions).

Whatever the model, a walker never takes a step that would overlap the robot or a wall. Where each walker
actually went is written to its :class:`WalkerTrack`, which :meth:`~navigation.world.MovingObstacle.position_at`
reads, so the collision check, the laser, the camera and the pictures all see the same walker.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .geometry import Pose2D
    from .world import Footprint, MovingObstacle, World

#: How a moving obstacle reacts to the robot (the world file's ``avoid`` field).
AVOID_MODES = ("stop", "sidestep", "none")
#: Seconds a stopped walker waits for the robot before it turns back.
PATIENCE = 4.0
#: A walker keeps its body this far from the robot's disc (metres).
GAP = 0.05
#: How far ahead a walker looks for the robot in its way (metres).
LOOK_AHEAD = 0.6
#: How far a side-stepping walker may leave its line (metres).
MAX_OFFSET = 1.0
#: Positions recorded per walker before the oldest half is thinned (hours of patrol at 10 Hz stay small).
MAX_TRACK = 200_000


@dataclass
class WalkerTrack:
    """Where one walker was at each simulated time since the simulation started: (t, x, y), times increasing."""

    times: list[float] = field(default_factory=list)
    xs: list[float] = field(default_factory=list)
    ys: list[float] = field(default_factory=list)

    def add(self, t: float, x: float, y: float) -> None:
        if self.times and t <= self.times[-1]:
            self.xs[-1], self.ys[-1] = x, y
            return
        if len(self.times) >= MAX_TRACK:  # keep every other old point: the picture needs the shape, not each step
            del self.times[:MAX_TRACK // 2:2], self.xs[:MAX_TRACK // 2:2], self.ys[:MAX_TRACK // 2:2]
        self.times.append(t)
        self.xs.append(x)
        self.ys.append(y)

    def at(self, t: float) -> tuple[float, float] | None:
        """Where the walker was at ``t`` (the last known place after the last record); None before the first."""
        if not self.times or t < self.times[0] - 1e-9:
            return None
        k = bisect.bisect_right(self.times, t + 1e-9) - 1
        return self.xs[k], self.ys[k]


@dataclass
class _Walker:
    """The state of one walker: distance ``s`` along its back-and-forth (0..2L) and offset ``e`` off its line."""

    obstacle: MovingObstacle
    s: float = 0.0
    e: float = 0.0
    waited: float = 0.0
    footprint: Footprint = field(init=False)
    track: WalkerTrack = field(init=False)

    def __post_init__(self) -> None:
        self.footprint = self.obstacle.body.footprint()
        assert self.obstacle.track is not None, "walkers step the moving obstacles of a live world"
        self.track = self.obstacle.track

    def normal(self) -> tuple[float, float]:
        """The unit left normal of the path (offsets ``e`` are measured along it)."""
        o = self.obstacle
        length = o.length
        return -(o.end[1] - o.start[1]) / length, (o.end[0] - o.start[0]) / length

    def place(self, s: float, e: float) -> tuple[float, float]:
        o = self.obstacle
        length = o.length
        fx, fy = (o.end[0] - o.start[0]) / length, (o.end[1] - o.start[1]) / length
        s = s % (2.0 * length)
        d = s if s <= length else 2.0 * length - s
        return o.start[0] + d * fx - e * fy, o.start[1] + d * fy + e * fx


class Crowd:
    """Steps every moving obstacle of a (live) world once per simulation step, given where the robot is.

    ``free(x, y, r)`` says whether a disc is clear of the walls and static things (the simulator's map check).
    """

    def __init__(self, world: World, free: Callable[[float, float, float], bool]) -> None:
        self.world = world
        self.free = free
        # Moving obstacles of a live world carry a track (static ones have none); one that cannot move stays put.
        self.walkers = [_Walker(o) for o in world.obstacles
                        if getattr(o, "track", None) is not None and o.length > 0.0 and o.speed > 0.0]
        for w in self.walkers:
            w.track.add(0.0, *w.obstacle.start)
        self.stops = 0  # steps a walker waited for the robot
        self.turns = 0  # times a walker turned back
        self.sidesteps = 0  # steps a walker spent off its line

    def step(self, t: float, dt: float, robot: Pose2D, robot_radius: float) -> None:
        for w in self.walkers:
            self._step(w, t, dt, robot, robot_radius)

    @staticmethod
    def _clear_of_robot(w: _Walker, x: float, y: float, robot: Pose2D, radius: float) -> bool:
        """Whether the walker's body placed at (x, y) keeps :data:`GAP` clear of the robot's disc."""
        fp = w.footprint
        return fp.distance(robot.x - x + fp.x, robot.y - y + fp.y) >= radius + GAP

    def _step(self, w: _Walker, t: float, dt: float, robot: Pose2D, radius: float) -> None:
        o = w.obstacle
        stride = o.speed * dt
        track = w.track
        if o.avoid == "none":
            w.s = (w.s + stride) % (2.0 * o.length)
            track.add(t, *w.place(w.s, 0.0))
            return
        x0, y0 = w.place(w.s, w.e)
        body_r = w.footprint.radius
        # Is the robot in the way within the look-ahead, on the current line?
        n_look = max(1, math.ceil(LOOK_AHEAD / max(stride, 1e-3)))
        blocked = any(not self._clear_of_robot(w, *w.place(w.s + k * stride, w.e), robot, radius)
                      for k in range(1, min(n_look, 40) + 1))
        target_e = 0.0
        if blocked and o.avoid == "sidestep":
            nx, ny = w.normal()
            lateral = (robot.x - x0) * nx + (robot.y - y0) * ny + w.e  # robot offset from the line
            need = radius + body_r + GAP + 0.05
            side = -1.0 if lateral >= w.e else 1.0
            target_e = None  # type: ignore[assignment]
            for e in (lateral + side * need, lateral - side * need):
                if abs(e) <= MAX_OFFSET and self.free(*w.place(w.s, e), body_r):
                    target_e = e
                    break
            if target_e is None:
                target_e = w.e  # no room either side: stay on this line and wait
            else:
                blocked = False  # it will pass beside the robot
        # Move towards the target offset, then along the line, each part only if it keeps clear.
        e_new = w.e + max(-stride, min(stride, target_e - w.e))
        if e_new != w.e:
            xe, ye = w.place(w.s, e_new)
            if self.free(xe, ye, body_r) and self._clear_of_robot(w, xe, ye, robot, radius):
                w.e = e_new
        if w.e != 0.0:
            self.sidesteps += 1
        s_new = w.s + stride
        xs, ys = w.place(s_new, w.e)
        if not blocked and (w.e == 0.0 or self.free(xs, ys, body_r)) and self._clear_of_robot(w, xs, ys, robot, radius):
            w.s = s_new % (2.0 * o.length)
            w.waited = 0.0
        else:
            self.stops += 1
            w.waited += dt
            if w.waited >= PATIENCE:  # the robot is not going away: turn back
                w.s = (2.0 * o.length - w.s) % (2.0 * o.length)
                w.waited = 0.0
                self.turns += 1
        track.add(t, *w.place(w.s, w.e))
