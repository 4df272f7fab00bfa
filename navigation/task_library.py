"""The built-in pose tasks, as Nav2's waypoint follower has them: wait, take a photo, look around.

Each is a :class:`~navigation.tasks.PoseTask` registered with :func:`~navigation.tasks.register_task`,
exactly as a task of your own would be. All waiting is on the simulation clock. The camera frames they
take stay with the visit, so a ``detect`` after a ``look_around`` sees every heading.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from declare import Bool, Float
from declare.fields import ListOf
from strictio import OutputError, write_atomically

from .geometry import wrap_angle
from .tasks import PoseTask, TaskContext, register_task

log = logging.getLogger(__name__)

#: Heading error (radians) at which a turn in place counts as done.
TURN_TOLERANCE = 0.03


@register_task
class WaitTask(PoseTask):
    """Stand still for a while (Nav2's WaitAtWaypoint)."""

    kind = "wait"
    state = "WAIT"
    summary = "stand still for some seconds"
    options = {"seconds": Float(2.0, "how long to wait, simulated seconds", min=0.0, max=86400.0)}  # noqa: RUF012
    positional = "seconds"

    def start(self, ctx: TaskContext) -> None:
        ctx.after(self.values["seconds"], lambda: ctx.succeed(f"waited {self.values['seconds']:g} s"))


def save_photo(folder: Path, frame: Any, stem: str, depth: bool) -> list[str]:
    """Write the colour image (PNG) and optionally the depth (16-bit PNG, millimetres, 0 = no return)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(str(folder), f"cannot create the photo folder: {exc.strerror or exc}") from None
    written = []
    ok, png = cv2.imencode(".png", frame.color)
    if not ok:
        raise OutputError(str(folder / f"{stem}.png"), "OpenCV cannot encode the image")
    write_atomically(folder / f"{stem}.png", png.tobytes())
    written.append(f"{stem}.png")
    if depth and getattr(frame, "depth", None) is not None:
        mm = np.nan_to_num(np.asarray(frame.depth, dtype=np.float64) * 1000.0, nan=0.0)
        ok, png = cv2.imencode(".png", np.clip(np.rint(mm), 0, 65535).astype(np.uint16))
        if ok:
            write_atomically(folder / f"{stem}_depth.png", png.tobytes())
            written.append(f"{stem}_depth.png")
    return written


@register_task
class PhotoTask(PoseTask):
    """Take a camera frame and save it (Nav2's PhotoAtWaypoint), after the robot has stood still a moment.

    Without an output folder (``PatrolMachine(output_dir=...)``) the frame is only kept for the tasks after
    this one at the pose, and the result says so.
    """

    kind = "photo"
    state = "PHOTO"
    summary = "save a camera frame (colour PNG, optionally depth)"
    options = {  # noqa: RUF012 - declarations, never mutated
        "settle": Float(0.5, "seconds to stand still before the shot", min=0.0, max=60.0),
        "depth": Bool(True, "also save the depth image (16-bit PNG, millimetres)"),
    }

    def start(self, ctx: TaskContext) -> None:
        def shoot() -> None:
            folder = ctx.machine.output_dir
            try:
                shot = ctx.capture("photo")
                if folder is None:
                    ctx.succeed("taken, not saved (no output folder)", files=[])
                    return
                stem = f"visit{ctx.visit.number:03d}_{ctx.visit.name}" if ctx.visit else f"photo_{ctx.now:.0f}"
                files = save_photo(folder, shot.frame, stem, self.values["depth"])
            except (RuntimeError, OutputError) as exc:
                ctx.fail(str(exc))
                return
            if ctx.visit is not None:
                ctx.visit.data.setdefault("photos", []).extend(files)
            ctx.succeed(f"saved {files[0]}", files=files)

        ctx.after(self.values["settle"], shoot)


@register_task
class LookAroundTask(PoseTask):
    """Turn in place to several headings (relative to the goal's), taking a frame at each."""

    kind = "look_around"
    state = "LOOK_AROUND"
    summary = "turn to several headings, one camera frame at each"
    options = {  # noqa: RUF012 - declarations, never mutated
        "headings": ListOf(Float(0.0, "degrees", min=-360.0, max=360.0), min_items=1, default=(-40.0, 0.0, 40.0),
                           doc="degrees relative to the goal heading, in order"),
        "settle": Float(0.3, "seconds to stand still before each frame", min=0.0, max=60.0),
        "speed": Float(1.0, "fastest turn, rad/s", min=0.05, max=1.9),
        "capture": Bool(True, "take a camera frame at each heading"),
    }
    positional = "headings"

    def start(self, ctx: TaskContext) -> None:
        base = ctx.visit.goal.yaw if ctx.visit is not None else ctx.pose().yaw
        targets = [wrap_angle(base + math.radians(h)) for h in self.values["headings"]]
        captures = 0

        def next_heading(k: int) -> None:
            nonlocal captures
            if k == len(targets):
                ctx.succeed(f"looked at {len(targets)} headings", captures=captures)
                return

            def arrived() -> None:
                nonlocal captures
                if self.values["capture"] and ctx.machine.camera is not None:
                    ctx.capture(f"heading {self.values['headings'][k]:g}")
                    captures += 1
                next_heading(k + 1)

            turn_to(ctx, targets[k], self.values["speed"], lambda: ctx.after(self.values["settle"], arrived))

        next_heading(0)


def turn_to(ctx: TaskContext, yaw: float, speed: float, then: Any) -> None:
    """Turn in place to ``yaw`` without overshooting at any time step; ``then()`` once there and still.

    The command is limited by what the base can brake from (its angular acceleration) and by a gain
    that shrinks with long time steps, so ``--dt 1.0`` converges instead of swinging. A turn that does not
    finish in a bounded time fails the task.
    """
    sim = ctx.sim
    dt = sim.config.dt
    accel = sim.robot.params.angular_accel
    gain = min(1.5, 0.8 / dt)
    min_speed = min(0.1, 0.5 * TURN_TOLERANCE / dt)
    start_error = abs(wrap_angle(yaw - ctx.pose().yaw))
    deadline = ctx.now + 10.0 + start_error / min(speed, 0.5)
    timer = None

    def step() -> None:
        error = wrap_angle(yaw - ctx.pose().yaw)
        if abs(error) < TURN_TOLERANCE:
            ctx.drive(0.0, 0.0)
            if abs(sim.robot.w) < 1e-3 and timer is not None:
                timer.cancel()
                then()
            return
        if ctx.now > deadline:
            ctx.fail(f"could not turn to {math.degrees(yaw):.0f} deg (still {math.degrees(error):.0f} deg off)")
            return
        w = min(speed, gain * abs(error), 0.8 * math.sqrt(2.0 * accel * abs(error)))
        ctx.drive(0.0, math.copysign(max(w, min_speed), error))

    timer = ctx.every(dt, step, first=0.0)
