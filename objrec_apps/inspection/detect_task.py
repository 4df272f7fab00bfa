"""The ``detect`` task: run an objrec parameter file on the camera frames taken at a pose.

It is registered with the patrol's task registry (:func:`navigation.tasks.register_task`) like any task
of one's own; the navigation package itself knows nothing of recognition. Frames reach the parameter
file's kind through the app's optional kind protocol (:class:`.camera_frames.TakesRGBD`), so a 2D file gets the
colour image and a 3D file an organized point cloud, and each object found is placed in the map (:mod:`.locate`).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from declare import Float
from declare.fields import FilePath, Invalid
from navigation.tasks import Capture, PoseTask, TaskContext, register_task
from objrec_core import (
    Kind,
    ParameterFileError,
    PipelineError,
    RecognitionSystem,
    UnknownModuleError,
    build_system,
    get_kind,
)

from .camera_frames import NoCameraFrames, TakesRGBD, camera_frames
from .locate import Sighting, locate

log = logging.getLogger(__name__)


#: Systems already built, by parameter file (resolved path, size, modification time): a mission that names one
#: file in many task lists builds it once, as one task shared by every pose already runs one system.
_BUILT: dict[tuple[str, int, int], tuple[RecognitionSystem, Kind]] = {}
_BUILT_MAX = 32


def _load(path: Path) -> tuple[RecognitionSystem, Kind]:
    """The system of a parameter file (built once per file and version), see :func:`_build`."""
    try:
        info = path.stat()
        key = (str(path.resolve()), info.st_size, info.st_mtime_ns)
    except OSError:
        return _build(path)  # build_system names the problem
    if key not in _BUILT:
        if len(_BUILT) >= _BUILT_MAX:
            _BUILT.pop(next(iter(_BUILT)))
        _BUILT[key] = _build(path)
    return _BUILT[key]


def _build(path: Path) -> tuple[RecognitionSystem, Kind]:
    """The system of a parameter file, refused unless it detects something and its kind takes camera frames
    (:class:`Invalid` on ``params``: the task's reader reports it at the option's line and key path)."""
    try:
        system = build_system(path)
        kind = get_kind(system.kind) if system.kind else None
    except (ParameterFileError, UnknownModuleError) as exc:
        raise Invalid(str(exc), "params") from None
    if kind is None or not system.detectors:
        raise Invalid(f"{path} has no detector, so nothing would be found", "params")
    try:
        camera_frames(kind)
    except NoCameraFrames as exc:
        raise Invalid(f"{path}: {exc}", "params") from None
    return system, kind


@register_task
class DetectTask(PoseTask):
    """Find objects with a parameter file in this visit's frames (after a look_around or photo), or in a new one."""

    kind = "detect"
    state = "DETECT"
    summary = "run an objrec parameter file on the camera frames taken here, place what it finds in the map"
    options = {  # noqa: RUF012 - declarations, never mutated
        "params": FilePath(required=True, doc="the parameter file (made with objrec-define)"),
        "settle": Float(0.3, "seconds to stand still before taking a frame when none was taken here",
                        min=0.0, max=60.0),
    }
    positional = "params"

    def __init__(self, **values: Any) -> None:
        super().__init__(**values)
        self.system, self.data_kind = _load(Path(self.values["params"]))
        self.labels = sorted({d.object_name for d in self.system.detectors})

    def describe(self) -> str:
        return f"detect {Path(self.values['params']).name}"

    def start(self, ctx: TaskContext) -> None:
        if ctx.visit is not None and ctx.visit.frames:
            self._run(ctx, list(ctx.visit.frames))
        elif ctx.machine.camera is None:
            ctx.fail("this patrol has no camera")
        else:
            ctx.after(self.values["settle"], lambda: self._run(ctx, [ctx.capture("detect")]))

    def _run(self, ctx: TaskContext, captures: list[Capture]) -> None:
        sightings: list[Sighting] = []
        kind, system = self.data_kind, self.system
        camera: TakesRGBD = camera_frames(kind)
        try:
            for shot in captures:
                f = shot.frame
                result = system.process(camera.from_rgbd(f.color, f.depth, f.fx, f.fy, f.cx, f.cy))
                sightings += locate(kind, system.object_array_type, list(result.objects), f, shot.pose,
                                    shot.label, shot.t)
        except PipelineError as exc:
            ctx.fail(f"{Path(self.values['params']).name}: {exc}")
            return
        if ctx.visit is not None:
            ctx.visit.data.setdefault("sightings", []).extend(sightings)
            ctx.visit.data.setdefault("looked_for", set()).update(self.labels)
        for s in sightings:
            ctx.emit("detection", params=Path(self.values["params"]).name, **s.as_dict())
        ctx.succeed(f"{len(sightings)} object(s) in {len(captures)} frame(s)", objects=len(sightings),
                    frames=len(captures))
