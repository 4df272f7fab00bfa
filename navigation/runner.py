"""Run a patrol to its end: step the simulation, honour Ctrl-C, SIGTERM and limits, optionally in real time.

Ctrl-C and SIGTERM do not raise here; they ask the machine to preempt, which ends in SHUTDOWN like any other
path, so the summary, the events file and the pictures are always written. A second one gives up at once.
A run flat out (not in real time) also ends, preempted the same way, after :data:`MAX_STEPS` steps: whatever
the time step, the batteries or the options, it never runs on unbounded.
"""

from __future__ import annotations

import contextlib
import logging
import time
from dataclasses import dataclass
from typing import Any

from strictio.signals import StopSignals

from .patrol import PatrolMachine

log = logging.getLogger(__name__)

# How long a preempted machine may take to reach SHUTDOWN (simulated seconds) before the run is cut.
PREEMPT_GRACE = 60.0
#: Steps a run flat out may take before it is preempted: at the default 0.1 s step, 27 simulated hours, more
#: than the batteries last; at the smallest step the command allows (0.01 s) still the whole default patrol.
MAX_STEPS = 1_000_000


@dataclass(frozen=True)
class Summary:
    """What the command prints on exit."""

    outcome: str | None
    final_states: tuple[str, ...]
    preempt_reason: str
    laps: int
    goals_reached: int
    goals_aborted: int
    goals_preempted: int
    distance: float
    odometry_drift: float
    collisions: int
    sim_time: float
    wall_time: float
    robot_battery: float
    laptop_battery: float
    # How far the pose navigation drove on was from the true pose, per step: zero with "exact".
    localization: str = "exact"
    localization_error_mean: float = 0.0
    localization_error_max: float = 0.0
    localization_updates: int = 0
    # How often amcl declared itself lost and found itself again; where it believed the robot was at the end, and
    # where the robot really was (None without a localizer or on a live robot, which knows no truth).
    localization_lost: int = 0
    localization_regained: int = 0
    believed_pose: tuple[float, float, float] | None = None
    true_pose: tuple[float, float, float] | None = None
    # The robot's clock is the wall clock (a live robot): sim_time is then real time.
    wall_clock: bool = False

    @property
    def speedup(self) -> float:
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")

    def as_dict(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome, "final_state": list(self.final_states), "reason": self.preempt_reason,
            "laps": self.laps, "goals_reached": self.goals_reached, "goals_aborted": self.goals_aborted,
            "goals_preempted": self.goals_preempted, "distance_m": round(self.distance, 2),
            "odometry_drift_m": round(self.odometry_drift, 3),
            "collisions": self.collisions, "sim_time_s": round(self.sim_time, 1),
            "wall_time_s": round(self.wall_time, 3), "robot_battery_percent": round(self.robot_battery, 1),
            "laptop_battery_percent": round(self.laptop_battery, 1),
            "localization": self.localization,
            "localization_error_mean_m": round(self.localization_error_mean, 3),
            "localization_error_max_m": round(self.localization_error_max, 3),
            "localization_updates": self.localization_updates,
            "localization_lost": self.localization_lost, "localization_regained": self.localization_regained,
            "believed_pose": _pose_dict(self.believed_pose), "true_pose": _pose_dict(self.true_pose),
        }


def _pose_dict(pose: tuple[float, float, float] | None) -> dict[str, float] | None:
    return None if pose is None else {"x": round(pose[0], 3), "y": round(pose[1], 3), "yaw": round(pose[2], 3)}


def _localizer_figures(robot: object) -> dict[str, Any]:
    """Lost/regained counts and the believed vs true pose from the simulator's localizer, if it has one."""
    loc = getattr(robot, "localizer", None)
    if loc is None or getattr(robot, "wall_clock", False):
        return {}
    return {"localization_lost": getattr(loc, "lost_count", 0),
            "localization_regained": getattr(loc, "regained_count", 0),
            "believed_pose": (loc.estimate.x, loc.estimate.y, loc.estimate.yaw),
            "true_pose": (loc.truth.x, loc.truth.y, loc.truth.yaw)}


def summarize(machine: PatrolMachine, wall_time: float) -> Summary:
    robot, st = machine.sim, machine.stats
    report = robot.report()
    return Summary(
        outcome=machine.outcome,
        final_states=tuple(machine.active_states()),
        preempt_reason=machine.preempt_reason or machine.end_reason,
        laps=st.laps, goals_reached=st.goals_reached, goals_aborted=st.goals_aborted,
        goals_preempted=st.goals_preempted, distance=report.distance, odometry_drift=report.odometry_drift,
        collisions=report.collisions,
        sim_time=robot.clock.now, wall_time=wall_time, robot_battery=robot.robot_battery.percentage,
        laptop_battery=robot.laptop_battery.percentage,
        localization=report.localization,
        localization_error_mean=report.localization_error_mean,
        localization_error_max=report.localization_error_max,
        localization_updates=report.localization_updates,
        wall_clock=robot.wall_clock,
        **_localizer_figures(robot),
    )


def run_patrol(machine: PatrolMachine, time_limit: float | None = None, realtime: bool = False,
               speed: float = 1.0, handle_sigint: bool = True, max_steps: int | None = MAX_STEPS) -> Summary:
    """Start the machine (if not started) and step until its outcome; returns the summary.

    ``time_limit`` (seconds of the robot's clock) preempts the patrol like Ctrl-C would, and so does
    ``max_steps`` on a simulation run flat out (None: no bound). With ``realtime`` the loop sleeps so that
    simulated time advances ``speed`` times as fast as the wall clock. A robot on the wall clock (a live one)
    is neither paced nor bounded in steps: its ``step`` waits for the world. ``handle_sigint`` turns SIGINT and
    SIGTERM into a preemption.
    """
    sim = machine.sim
    if not machine.entered:
        machine.begin()
    wall0 = time.perf_counter()
    sim0 = sim.clock.now
    paced = realtime and not sim.wall_clock
    steps = 0
    step_limit = None if realtime or sim.wall_clock or max_steps is None else max_steps
    preempt_at: float | None = None
    flag = StopSignals() if handle_sigint else None
    with flag if flag is not None else contextlib.nullcontext():
        while not machine.finished:
            if flag is not None and flag.count and not machine.preempt_requested:
                log.info("%s: preempting the patrol", flag.reason)
                machine.request_preempt(flag.reason)
            if time_limit is not None and sim.clock.now >= time_limit and not machine.preempt_requested:
                machine.request_preempt("time limit")
            if step_limit is not None and steps >= step_limit and not machine.preempt_requested:
                log.info("%d steps run: preempting the patrol", max_steps)
                machine.request_preempt(f"step limit of {max_steps} steps")
            if machine.preempt_requested:
                preempt_at = sim.clock.now if preempt_at is None else preempt_at
                if sim.clock.now - preempt_at > PREEMPT_GRACE:
                    log.warning("the machine did not reach SHUTDOWN %g s after preemption; halting", PREEMPT_GRACE)
                    sim.halt()
                    break
            sim.step()
            steps += 1
            if paced:
                ahead = (sim.clock.now - sim0) / speed - (time.perf_counter() - wall0)
                if ahead > 0:
                    time.sleep(ahead)
    return summarize(machine, time.perf_counter() - wall0)
