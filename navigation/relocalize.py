"""What a robot does when it knows it is lost: stop, turn and look, re-seed its particles, and say when it gives up.

A lost amcl (:attr:`navigation.localization.Amcl.lost`: the cloud too wide, or most beams off the map at the
estimate) drives the patrol into its LOCALIZE state, which runs a :class:`Relocalize`. Driving on a wrong pose
plans through walls ("start is in an obstacle") and spins through every remaining goal; standing still and
turning gives the filter a full ring of fresh scans without moving the robot anywhere it does not know.

The stages follow augmented MCL (Thrun, Burgard and Fox, ch. 8.3): first the cloud as it is (a walker that hid
the walls has gone), then a cloud re-seeded around the last estimate that was trusted (the estimate slid), then
a search of the whole free map (the robot was carried off: the kidnapped robot). Each stage turns the robot
``turns_per_stage`` times on the spot; the first moment the filter is confident again the action succeeds, and
after the last stage it fails with the reason.

The global stage does not spread particles over the map and weigh them one narrow scan at a time (that cloud
collapses onto whatever sees a wall where the first scan did); it scores poses over the whole map against the
full turn of scans the robot has just taken (:mod:`navigation.amcl_global`), checks the best by casting that turn
on the map, and re-seeds the filter around it. amcl must then confirm it over ``trial_turns`` more turns, or the
next hypothesis is tried. When two distinct places explain the turn equally well (a symmetric room), the robot
says so and gives up instead of driving on a guess; when several lie along one line (a corridor whose walls look
the same all along), it says it cannot tell where along the corridor it is.

:func:`schedule_kidnap` is the other half of the lesson: it teleports the true robot at a simulated time, which
its odometry never notices.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .amcl_global import (
    GlobalSearchParams,
    Hypothesis,
    along_a_line,
    ambiguity,
    latest_turn,
    same_view,
    search,
    second_opinion,
    yaw_covered,
)
from .clock import Timer
from .geometry import Pose2D
from .localization import Amcl, ScanView, compose, inverse
from .move_base import GoalStatus

if TYPE_CHECKING:
    from .simulation import Simulation

log = logging.getLogger(__name__)

STAGES = ("scan", "local", "global")


@dataclass(frozen=True)
class RelocalizeParams:
    """``turn_speed`` rad/s on the spot; each stage lasts ``turns_per_stage`` full turns (the global one
    ``global_turns``: a full turn for the search, then ``trial_turns`` for each hypothesis tried); the local
    re-seed is a Gaussian of ``local_sigma_xy`` m and ``local_sigma_yaw`` rad around the last trusted estimate.
    Lost again within ``relapse_window`` s of a relocalisation, the robot starts at the stage after the one that
    seemed to work: that pose was wrong. The global stage waits for a full turn of scans taken since LOCALIZE
    began, searches the map with ``search`` and gives each acceptable hypothesis ``trial_turns`` turns for amcl
    to confirm it."""

    turn_speed: float = 0.6
    turns_per_stage: float = 2.5
    global_turns: float = 5.0
    relapse_window: float = 60.0
    local_sigma_xy: float = 0.5
    local_sigma_yaw: float = 0.5
    poll_period: float = 0.1
    trial_turns: float = 1.5
    search: GlobalSearchParams = field(default_factory=GlobalSearchParams)

    def __post_init__(self) -> None:
        for name in ("turn_speed", "turns_per_stage", "global_turns", "relapse_window", "local_sigma_xy",
                     "local_sigma_yaw", "poll_period", "trial_turns"):
            if not getattr(self, name) > 0:
                raise ValueError(f"relocalize {name} must be positive, got {getattr(self, name)}")

    def stage_seconds(self, stage: str) -> float:
        turns = self.global_turns if stage == "global" else self.turns_per_stage
        return turns * 2.0 * math.pi / self.turn_speed


class Relocalize:
    """The LOCALIZE action on the simulator: turn in place through the stages until amcl trusts its pose.

    ``robot`` is the :class:`~navigation.simulation.Simulation` (its ``teleop`` turns the base while no goal
    runs, its ``localizer`` is the :class:`~navigation.localization.Amcl`, its ``clock`` paces the stages).
    ``done(status, text)`` is called once: SUCCEEDED when the pose is trusted again, ABORTED with the reason.
    """

    def __init__(self, robot: Simulation, params: RelocalizeParams | None = None) -> None:
        self.robot = robot
        self.params = params or RelocalizeParams()
        self.stage = ""
        self._timer: Timer | None = None
        self._done: Callable[[GoalStatus, str], None] | None = None
        self._stage_end = 0.0
        self._stage_index = -1
        self._found_at: float | None = None
        self._found_stage = -1
        self._since = 0.0  # when this LOCALIZE began: only scans from then on show where the robot is now
        self._hypotheses: list[Hypothesis] | None = None  # the global search's, still to try
        self._searched_at = Pose2D(0.0, 0.0, 0.0)  # the odometry pose the hypotheses are poses of the robot at
        self._trial_end: float | None = None
        self._trials: list[str] = []
        amcl = getattr(robot, "localizer", None)
        if isinstance(amcl, Amcl):
            amcl.confirm = self._second_opinion

    @property
    def active(self) -> bool:
        return self._done is not None

    def start(self, done: Callable[[GoalStatus, str], None]) -> None:
        if not isinstance(getattr(self.robot, "localizer", None), Amcl) or not hasattr(self.robot, "teleop"):
            done(GoalStatus.ABORTED, "localization lost and this robot cannot relocalise from the patrol "
                                     "(needs the simulator with --localization amcl)")
            return
        self._done = done
        self._since = self.robot.clock.now
        relapse = self._found_at is not None and self.robot.clock.now - self._found_at <= self.params.relapse_window
        self._stage_index = min(self._found_stage, len(STAGES) - 2) if relapse else -1
        self._next_stage()
        self._timer = self.robot.clock.every(self.params.poll_period, self._poll)

    def cancel(self) -> None:
        """Stop turning; no result is delivered."""
        self._finish()

    def _finish(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self._done is not None:
            self.robot.teleop = None
        self._done = None

    def _amcl(self) -> Amcl:
        amcl = self.robot.localizer
        assert isinstance(amcl, Amcl)
        return amcl

    def _next_stage(self) -> None:
        robot = self.robot
        amcl = self._amcl()
        self._stage_index += 1
        self.stage = STAGES[self._stage_index]
        p = self.params
        if self.stage == "local":
            amcl.set_pose(amcl.last_good, p.local_sigma_xy, p.local_sigma_yaw)
        elif self.stage == "global":
            self._hypotheses, self._trial_end, self._trials = None, None, []
        self._stage_end = robot.clock.now + p.stage_seconds(self.stage)
        robot.teleop = (0.0, p.turn_speed)
        robot.events.emit("relocalize", stage=self.stage, particles=amcl.particles, **amcl.pose_fields())
        log.info("relocalising: stage %s", self.stage)

    def _poll(self) -> None:
        if self._done is None:
            return
        amcl = self._amcl()
        done = self._done
        if not amcl.lost:
            self._found_at, self._found_stage = self.robot.clock.now, self._stage_index
            self._finish()
            done(GoalStatus.SUCCEEDED, f"relocalised in stage {self.stage}")
            return
        if self.stage == "global":
            problem = self._global_step(amcl)
            if problem:
                self._give_up(problem)
                return
        if self.robot.clock.now < self._stage_end:
            return
        if self._stage_index + 1 < len(STAGES):
            self._next_stage()
            return
        problem = amcl.confidence.problem(amcl.params) or "not confident long enough"
        if self._trials:
            problem = f"amcl did not confirm {'; '.join(self._trials)}: {problem}"
        self._give_up(problem)

    def _give_up(self, problem: str) -> None:
        done = self._done
        self._finish()
        if done is not None:
            done(GoalStatus.ABORTED, f"localization lost: no confident pose after {', '.join(STAGES)} ({problem})")

    def _ring(self, amcl: Amcl) -> list[ScanView]:
        """The latest scans taken since LOCALIZE began, as few as cover a full turn; [] until they do."""
        fov = amcl.laser.fov
        views = latest_turn(amcl.views, self._since, fov)
        return views if yaw_covered(views, fov) >= 2.0 * math.pi - 1e-6 else []

    def _second_opinion(self, pose: Pose2D) -> str:
        """amcl asks before it trusts a pose again: checked against the scans since it was lost (see
        :func:`navigation.amcl_global.second_opinion`)."""
        amcl = self._amcl()
        views = latest_turn(amcl.views, amcl.lost_at, amcl.laser.fov)
        if not views:
            return ""
        return second_opinion(amcl.filter, views, amcl.odom, amcl.laser, pose, self.params.search)

    def _global_step(self, amcl: Amcl) -> str:
        """Search once a full turn is in, then try the hypotheses in turn; why to give up, or ""."""
        now = self.robot.clock.now
        if self._hypotheses is None:
            ring = self._ring(amcl)
            if not ring:
                return ""  # keep turning
            if not any(np.isfinite(v.scan.ranges).any() for v in ring):
                return f"no wall within the laser's {ring[0].scan.range_max:g} m in a full turn"
            p = self.params.search
            found = search(amcl.filter, ring, amcl.odom, amcl.laser, p)
            self._searched_at = amcl.odom
            self.robot.events.emit("global_search", views=len(ring), hypotheses=[
                {"x": round(h.pose.x, 3), "y": round(h.pose.y, 3), "yaw": round(h.pose.yaw, 3),
                 "agreement": round(h.agreement, 3)} for h in found])
            twin = ambiguity(found, p)
            if twin is not None:
                return along_a_line(found, p) or f"{same_view(found[0], twin)}: it cannot tell where the robot is"
            self._hypotheses = [h for h in found if h.agreement >= p.accept]
            if not self._hypotheses:
                best = f"; best {found[0].describe()}" if found else ""
                return f"no place on the map explains a full turn of scans ({p.accept:.0%} of beams needed{best})"
        if self._trial_end is not None and now < self._trial_end:
            return ""
        if not self._hypotheses:
            return ""  # every hypothesis tried: the stage's end gives up
        h = self._hypotheses.pop(0)
        pose = compose(h.pose, compose(inverse(self._searched_at), amcl.odom))  # the robot turned since the search
        amcl.set_pose(pose)
        self._trials.append(h.describe())
        self._trial_end = now + self.params.trial_turns * 2.0 * math.pi / self.params.turn_speed
        self.robot.events.emit("global_trial", trial=len(self._trials), agreement=round(h.agreement, 3),
                               **amcl.pose_fields())
        log.info("relocalising: trying %s", h.describe())
        return ""


def schedule_kidnap(robot: Simulation, when: float, pose: Pose2D) -> Timer:
    """Teleport the true robot to ``pose`` at simulated time ``when``; its odometry and amcl are not told.

    The ``kidnap`` event carries where it was taken from and to. A pose inside an obstacle is refused at once.
    """
    collides = robot._collides
    radius = robot.config.robot.radius
    if collides(pose.x, pose.y, radius):
        raise ValueError(f"kidnap pose ({pose.x:g}, {pose.y:g}) is off the map or inside an obstacle")

    def teleport() -> None:
        base = robot.robot
        before = base.pose
        base.set_pose(pose)
        base.stop()
        robot.events.emit("kidnap", **{"from": before.as_dict(), "to": pose.as_dict()})
        log.info("kidnapped the robot from (%.2f, %.2f) to (%.2f, %.2f)", before.x, before.y, pose.x, pose.y)

    return robot.clock.call_at(when, teleport)
