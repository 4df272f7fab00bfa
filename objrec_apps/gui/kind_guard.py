"""Frames of another data kind never reach the pipeline.

When File > Open replaces a running 3D pipeline by a 2D one, the processing thread may hold a cloud it read
(and checked against the old pipeline's kind) while it waits for the processing lock that the load holds;
once the lock is free that cloud went through the new image pipeline ("processing frame failed ... got a
PointCloud"). The director runs the pipeline under that lock, so it is where the frame's data is checked
against the pipeline's kind as it is then: a frame of another kind is skipped, not an error.
"""

from __future__ import annotations

import logging
from typing import Any

from objrec_core import DefinitionDirector, Frame, StageResults, UnknownModuleError, get_kind

log = logging.getLogger(__name__)


class KindGuardedDirector(DefinitionDirector):
    """A DefinitionDirector that skips (returns None for) a frame whose data is not the pipeline's kind."""

    #: Frames skipped so (for tests and the log).
    skipped = 0

    def process(self, frame: Frame | Any) -> StageResults | None:  # type: ignore[override]
        data = frame.data if isinstance(frame, Frame) else frame
        name = self.system.kind
        if name is not None:
            try:
                kind = get_kind(name)
            except UnknownModuleError:
                kind = None
            if kind is not None and not kind.is_frame(data):
                self.skipped += 1
                log.debug("a frame of %s skipped: the pipeline now works on %s", type(data).__name__, name)
                return None
        return super().process(frame)
