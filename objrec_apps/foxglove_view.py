"""``objrec-detect --foxglove [HOST:]PORT``: the run served live to Foxglove (or Lichtblick), the ``viz`` extra.

Channels, all stamped with the frame's header stamp (the one its detections carry) and in its frame_id:

- ``/objrec/input``: the input frame: ``foxglove.RawImage`` (bgr8) for image kinds, ``foxglove.PointCloud``
  for kinds whose views show points (``Kind.has_points``);
- ``/objrec/stages/<filter id>``: each filter's output, by the same rule (a mask as its preview picture);
- ``/objrec/detections``: the detected objects: ``foxglove.ImageAnnotations`` (a closed outline and a text
  label per object, in the image's pixels: the Image panel draws them over the input or any stage) for image
  kinds, ``foxglove.SceneUpdate`` (boxes, spheres, cylinders with labels, :mod:`objrec_apps.foxglove_scene`)
  for point kinds;
- ``/objrec/timing``: JSON per frame: ``frame`` (index), ``stamp`` (seconds), ``seconds`` (the run loop's
  time on the frame outside this view: reading it, the pipeline and the other outputs), ``objects``.

The view is an annotation sink of the director; it never blocks detection (see :mod:`foxgloveio.server`:
a slow viewer loses messages, and nothing is built for a channel nobody subscribes to).
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Sequence
from typing import IO, Any

import numpy as np

from foxgloveio.server import (
    OPTION,
    Address,
    FoxgloveUnavailable,
    LiveServer,
    add_foxglove_argument,
    timestamp,
)
from objrec_core import DetectedObjectArray, DetectionDirector, Frame, FrameKindError, Kind, RecognitionSystem, Stage

from .cli import UserError
from .foxglove_scene import point_cloud_message, scene_update
from .output_contract import Output, RunEnd

__all__ = ["OPTION", "FoxgloveView", "add_foxglove_argument", "image_annotations"]

log = logging.getLogger(__name__)

INPUT_TOPIC = "/objrec/input"
STAGE_TOPIC = "/objrec/stages/"
DETECTIONS_TOPIC = "/objrec/detections"
TIMING_TOPIC = "/objrec/timing"
#: Outline colour (RGBA, 0..1): the green of the annotated pictures.
OUTLINE_RGBA = (0.0, 1.0, 0.0, 1.0)
OUTLINE_THICKNESS = 2.0
LABEL_FONT_SIZE = 14.0
TIMING_SCHEMA = {
    "title": "objrec.FrameTiming", "type": "object",
    "properties": {"frame": {"type": "integer", "description": "the frame's index in the run"},
                   "stamp": {"type": "number", "description": "the frame's header stamp, seconds"},
                   "seconds": {"type": "number", "description": "run loop time on the frame outside this view"},
                   "objects": {"type": "integer", "description": "objects detected"}},
}


def raw_image(picture: Any, stamp: Any, frame_id: str) -> Any:
    """A ``foxglove.RawImage`` of a BGR ``uint8`` picture (a grey one as mono8)."""
    from foxglove.messages import RawImage

    image = np.ascontiguousarray(picture, dtype=np.uint8)
    height, width = image.shape[:2]
    channels = 1 if image.ndim == 2 else image.shape[2]
    encoding = {1: "mono8", 3: "bgr8", 4: "bgra8"}[channels]
    return RawImage(timestamp=stamp, frame_id=frame_id, width=width, height=height, encoding=encoding,
                    step=width * channels, data=image.tobytes())


def image_annotations(kind: Kind, objects: DetectedObjectArray, stamp: Any) -> Any:
    """A ``foxglove.ImageAnnotations``: per object its outline (a line loop through the polygon's pixels)
    and its label at the outline's top left corner."""
    from foxglove.messages import (
        Color,
        ImageAnnotations,
        Point2,
        PointsAnnotation,
        PointsAnnotationType,
        TextAnnotation,
    )

    colour = Color(**dict(zip("rgba", OUTLINE_RGBA, strict=True)))
    outlines, texts = [], []
    for outline in kind.outlines(objects):
        if outline.polygon is None:
            continue
        polygon = np.asarray(outline.polygon, dtype=np.float64).reshape(-1, 2)
        if len(polygon) < 2 or not np.isfinite(polygon).all():
            continue
        outlines.append(PointsAnnotation(timestamp=stamp, type=PointsAnnotationType.LineLoop,
                                         points=[Point2(x=float(x), y=float(y)) for x, y in polygon],
                                         outline_color=colour, thickness=OUTLINE_THICKNESS))
        corner = polygon.min(axis=0)
        texts.append(TextAnnotation(timestamp=stamp, position=Point2(x=float(corner[0]), y=float(corner[1])),
                                    text=outline.label, font_size=LABEL_FONT_SIZE, text_color=colour,
                                    background_color=Color(r=0.0, g=0.0, b=0.0, a=0.6)))
    return ImageAnnotations(timestamp=stamp, points=outlines, texts=texts)


class FoxgloveSink:
    """The annotation sink (``sink(frame, objects, stages)``) that logs each frame to a :class:`LiveServer`."""

    def __init__(self, server: LiveServer, kind: Kind, stage_ids: Sequence[str]) -> None:
        from foxglove.channels import ImageAnnotationsChannel, PointCloudChannel, RawImageChannel, SceneUpdateChannel

        self.server, self.kind = server, kind
        data_channel = PointCloudChannel if kind.has_points else RawImageChannel
        self.input = server.channel(data_channel, INPUT_TOPIC)
        self.stages = {i: server.channel(data_channel, STAGE_TOPIC + i) for i in stage_ids}
        self.detections = server.channel(SceneUpdateChannel if kind.has_points else ImageAnnotationsChannel,
                                         DETECTIONS_TOPIC)
        self.timing = server.json_channel(TIMING_TOPIC, TIMING_SCHEMA)
        self.frames = 0
        self._ready = time.perf_counter()

    def __call__(self, frame: Frame, objects: DetectedObjectArray, stages: Sequence[Stage] | None) -> None:
        seconds = time.perf_counter() - self._ready
        wanted = self.server.wanted
        header = objects.header
        stamp_dict = header.to_dict()["stamp"]  # exactly as the detections' JSON lines and typed messages
        when = int(stamp_dict["secs"]) * 1_000_000_000 + int(stamp_dict["nsecs"])
        stamp = timestamp(when)
        frame_id = str(header.frame_id)
        if wanted(self.input):
            self._log_data(self.input, frame.data, stamp, frame_id, when)
        for stage in stages or ():
            channel = self.stages.get(stage.id) if stage.role == "filter" else None
            if channel is not None and wanted(channel):
                self._log_data(channel, stage.output, stamp, frame_id, when)
        if wanted(self.detections):
            message = (scene_update(self.kind, objects, stamp, frame_id) if self.kind.has_points
                       else image_annotations(self.kind, objects, stamp))
            self.detections.log(message, log_time=when)
        if wanted(self.timing):
            self.timing.log({"frame": int(frame.index), "stamp": float(header.stamp), "seconds": seconds,
                             "objects": len(objects.objects)}, log_time=when)
        self.frames += 1
        self._ready = time.perf_counter()

    def _log_data(self, channel: Any, data: Any, stamp: Any, frame_id: str, when: int) -> None:
        kind = self.kind
        try:
            if kind.has_points:
                points = kind.points(data)
                if points is None:
                    return
                message = point_cloud_message(points, getattr(data, "colors", None), stamp, frame_id)
            else:
                message = raw_image(kind.preview(data), stamp, frame_id)
        except FrameKindError as exc:  # a stage whose output the kind cannot show: say so, keep serving
            log.debug("%s not served: %s", channel.topic(), exc)
            return
        channel.log(message, log_time=when)


class FoxgloveView(Output):
    """``--foxglove [HOST:]PORT``: every frame, stage and detection served live (see the module's text)."""

    option = OPTION

    def __init__(self, address: Address, kind: Kind, system: RecognitionSystem, *, prog: str = "objrec-detect",
                 announce: IO[str] | None = None) -> None:
        super().__init__(None)
        try:
            self.server = LiveServer(address, prog)
        except FoxgloveUnavailable as exc:
            raise UserError(str(exc)) from None
        try:
            self.sink = FoxgloveSink(self.server, kind, [m.id for m in system.filters])
        except Exception:
            self.server.close()
            raise
        stream = announce if announce is not None else sys.stderr
        stream.write(f"{prog}: Foxglove live view on {self.server.url}\n")
        stream.flush()

    def attach(self, director: DetectionDirector) -> None:
        director.keep_stages = True
        director.add_annotation_sink(self.sink)

    def close(self, end: RunEnd) -> None:
        self.server.close()

    def summary(self) -> str:
        return f"{self.sink.frames} frames served live to Foxglove on {self.server.url}"
