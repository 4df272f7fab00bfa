"""Where the detections themselves go: JSON Lines (a file or stdout) or typed ROS messages (MCAP, bags).

The same two outputs serve objrec-detect's ``--output`` and each source of objrec-batch, so both commands
write whole lines on a full disk and complete (or drop) a typed file by the same rule.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from objrec_core import DetectedObjectArray, DetectionDirector, JSONLinesSink

from .cli import open_text_output
from .output_contract import Output, RunEnd
from .outputs import open_typed_writer

#: The option that names the detections' output.
OUTPUT_OPTION = "--output"


class DetectionLines(Output):
    """One JSON line per frame into ``path`` (whole lines only, missing folders made), else into ``stream``."""

    option = OUTPUT_OPTION

    def __init__(self, path: str | Path | None, stream: IO[str] | None = None, skip_empty: bool = False) -> None:
        super().__init__(str(path) if path else None)
        self._file = open_text_output(self.path) if self.path else None
        target = self._file or stream
        if target is None:
            raise ValueError("DetectionLines needs a path or a stream")
        self.sink = JSONLinesSink(target, skip_empty=skip_empty)

    def attach(self, director: DetectionDirector) -> None:
        director.add_sink(self.sink)

    def close(self, end: RunEnd) -> None:
        if self._file is not None:  # a stream given stays open for its owner
            self._file.close()


class TypedDetections(Output):
    """Typed detection messages on one topic in an MCAP file, a ROS 1 bag or a ROS 2 bag folder.

    The file is completed with everything written so far, also after a stop or a source that broke half way;
    it is left out entirely where the run wrote nothing usable (``RunEnd.keep_partial`` false).
    """

    option = OUTPUT_OPTION

    def __init__(self, path: str | Path, array_type: type[DetectedObjectArray], topic: str, copy: Any = None,
                 skip_empty: bool = False) -> None:
        super().__init__(str(path))
        self.writer = open_typed_writer(str(path), array_type, topic, copy)
        self._skip_empty = skip_empty

    def attach(self, director: DetectionDirector) -> None:
        director.add_sink(_skipping_empty(self.writer) if self._skip_empty else self.writer)

    def close(self, end: RunEnd) -> None:
        if end.keep_partial:
            self.writer.close()
        else:
            self.writer.abort()

    def summary(self) -> str:
        return f"{self.writer.count} messages on {self.writer.topic} written to {self.path}"


def _skipping_empty(sink: Callable[[DetectedObjectArray], None]) -> Callable[[DetectedObjectArray], None]:
    def write(array: DetectedObjectArray) -> None:
        if array.objects:
            sink(array)

    return write
