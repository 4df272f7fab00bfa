"""Rerun recordings of a detection run (``objrec-detect --rerun out.rrd|spawn``, the ``viz`` extra).

One recording holds, per frame, on a ``frame`` timeline (the frame's index) and a ``stamp`` timeline (the
frame's time stamp, the one its detections carry):

- ``input/frame``: the input, as 3D points (``rr.Points3D``, with the frame's colours where it has them)
  for kinds whose views show points, else as the kind's preview picture (``rr.Image``, BGR);
- ``input/detections``: the detected objects, closed polygons (``rr.LineStrips2D``) over the picture or
  oriented boxes (``rr.Boxes3D``) among the points, each labelled with its name;
- ``stages/<filter id>/frame``: each filter's output, by the same rule as the input;
- ``stats/frame_seconds`` and ``stats/objects``: scalars per frame (see :class:`RerunRecorder`).

Everything goes through the kind contract (``preview``, ``points``, ``outlines``), so any registered
kind records without this module knowing it. rerun-sdk is imported only by :func:`open_rerun`: the
module itself loads without the extra. Nothing here writes to stdout (objrec-detect streams JSON there);
a spawned viewer's stdout goes to the null device.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from objrec_core import DetectedObjectArray, Frame, FrameKindError, Kind, RecognitionSystem, Stage
from rerunio import VIEWER_PORT, Recorder, import_rerun, open_stream

log = logging.getLogger(__name__)

#: Colour of detection outlines (RGB): the green the annotated pictures use as well.
DETECTION_COLOUR = (0, 255, 0)


def quaternion_xyzw(rotation: np.ndarray) -> np.ndarray:
    """The unit quaternion (x, y, z, w) of a 3 x 3 rotation matrix (Shepperd's method: no division by
    a small number whatever the angle)."""
    m = np.asarray(rotation, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    quaternion = np.asarray(q)
    return quaternion / np.linalg.norm(quaternion)


def box_pose(corners: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre, half sizes and rotation (quaternion x, y, z, w) of an oriented box from its 8 corners.

    Corner ``i`` lies at ``-/+`` half a side along the box's local x, y, z by bits 2, 1, 0 of ``i``
    (``objrec_core.Outline``), so corners 4, 2 and 1 are corner 0 moved along one local axis each. The
    rotation is the nearest proper rotation to those three edges (a polar decomposition), which is exact
    for a true box and still defined for a flat one.
    """
    c = np.asarray(corners, dtype=np.float64).reshape(8, 3)
    edges = np.column_stack((c[4] - c[0], c[2] - c[0], c[1] - c[0]))
    half_sizes = np.linalg.norm(edges, axis=0) / 2.0
    u, _, vt = np.linalg.svd(edges)
    if np.linalg.det(u @ vt) < 0:  # mirrored corners: turn the least certain axis round
        u[:, -1] = -u[:, -1]
    return c.mean(axis=0), half_sizes, quaternion_xyzw(u @ vt)


# -- the recorder -----------------------------------------------------------------------------------
def _entity(stage_id: str) -> str:
    from rerun import escape_entity_path_part

    return f"stages/{escape_entity_path_part(stage_id)}"


def detection_blueprint(kind: Kind, stage_ids: Sequence[str]) -> Any:
    """One view of the input with its detections, one per filter output, and the per-frame scalars."""
    import rerun.blueprint as rrb

    view = rrb.Spatial3DView if kind.has_points else rrb.Spatial2DView
    views = [view(origin="/input", name="input and detections")]
    views += [view(origin=f"/{_entity(i)}", contents=["$origin/**", "/input/detections"], name=i)
              for i in stage_ids]
    plots = rrb.Horizontal(rrb.TimeSeriesView(origin="/stats/frame_seconds", name="seconds per frame"),
                           rrb.TimeSeriesView(origin="/stats/objects", name="objects per frame"))
    return rrb.Blueprint(rrb.Vertical(rrb.Grid(*views), plots, row_shares=[4, 1]))


class RerunRecorder(Recorder):
    """An annotation sink (``recorder(frame, objects, stages)``) that logs each frame to a recording.

    Give the director ``keep_stages=True`` for the filter outputs; without stages only the input, the
    detections and the scalars are logged.

    ``stats/frame_seconds`` is the wall time the run loop spent on a frame outside this recorder: from
    the end of the previous call (for the first frame, from the recorder's creation) to the start of this
    one, which covers reading the frame, the pipeline and the other sinks, and leaves out the recorder's
    own logging. ``stats/objects`` is the number of objects found in the frame. A failed write is noticed
    every ``rerunio.CHECK_EVERY`` frames (``rerunio.Recorder``).
    """

    def __init__(self, recording: Any, kind: Kind) -> None:
        super().__init__(recording)
        self.kind = kind
        if kind.has_points:
            # A point cloud's sensor frame: x right, y down, z forward. Only the viewer's camera uses it.
            recording.log("/", self._rr.ViewCoordinates.RDF, static=True)
        self._ready = time.perf_counter()

    def __call__(self, frame: Frame, objects: DetectedObjectArray, stages: Sequence[Stage] | None) -> None:
        seconds = time.perf_counter() - self._ready
        rr, rec = self._rr, self.recording
        self.set_time("frame", sequence=int(frame.index))
        self.set_time("stamp", timestamp=float(objects.header.stamp))
        self._log_data("input/frame", frame.data)
        for stage in stages or ():
            if stage.role == "filter":
                self._log_data(f"{_entity(stage.id)}/frame", stage.output)
        self._log_objects(objects)
        rec.log("stats/frame_seconds", rr.Scalars(seconds))
        rec.log("stats/objects", rr.Scalars(float(len(objects.objects))))
        self.step_logged()
        self._ready = time.perf_counter()

    @property
    def frames(self) -> int:
        """Frames logged so far."""
        return self.steps

    def _log_data(self, path: str, data: Any) -> None:
        rr, kind = self._rr, self.kind
        try:
            points = kind.points(data) if kind.has_points else None
            if points is None:
                self.recording.log(path, rr.Image(kind.preview(data), color_model="BGR"))
                return
        except FrameKindError as exc:  # a stage whose output the kind cannot show: say so, keep recording
            log.debug("%s not recorded: %s", path, exc)
            return
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        keep = np.isfinite(points).all(axis=1)
        colours = getattr(data, "colors", None)
        if colours is not None:
            colours = np.asarray(colours)
            colours = colours[keep] if colours.shape == points.shape else None
        self.recording.log(path, rr.Points3D(points[keep], colors=colours))

    def _log_objects(self, objects: DetectedObjectArray) -> None:
        rr = self._rr
        outlines = self.kind.outlines(objects)
        if self.kind.has_points:
            boxes = [(o.label, np.asarray(o.box, dtype=np.float64)) for o in outlines if o.box is not None]
            boxes = [(label, box) for label, box in boxes if box.shape in ((8, 3), (24,)) and np.isfinite(box).all()]
            poses = [box_pose(box) for _, box in boxes]
            self.recording.log("input/detections", rr.Boxes3D(
                centers=[p[0] for p in poses], half_sizes=[p[1] for p in poses],
                quaternions=[rr.Quaternion(xyzw=p[2]) for p in poses], labels=[label for label, _ in boxes],
                colors=[DETECTION_COLOUR] * len(boxes)))
            return
        strips, labels = [], []
        for outline in outlines:
            if outline.polygon is None:
                continue
            polygon = np.asarray(outline.polygon, dtype=np.float32).reshape(-1, 2)
            if len(polygon) >= 2:
                strips.append(np.vstack((polygon, polygon[:1])))  # closed
                labels.append(outline.label)
        self.recording.log("input/detections",
                           rr.LineStrips2D(strips, labels=labels, colors=[DETECTION_COLOUR] * len(strips)))


def open_rerun(target: str | os.PathLike[str], kind: Kind, system: RecognitionSystem | None = None, *,
               port: int = VIEWER_PORT) -> RerunRecorder:
    """A recorder logging to ``target`` (a path ending in ``.rrd``, or ``spawn`` for a viewer).

    ``system`` names the filters, whose outputs get a view each in the recording's layout. Raises
    :class:`RerunUnavailable` with a one-line message when rerun-sdk is missing (install objrec[viz]),
    no viewer can be spawned, or the file cannot be written.
    """
    import_rerun()
    stage_ids = [m.id for m in system.filters] if system is not None else []
    blueprint = detection_blueprint(kind, stage_ids)
    stream = open_stream(target, "objrec", blueprint, port)
    recorder = RerunRecorder(stream, kind)
    recorder.target = str(target)
    return recorder
