"""Why nothing was found, headless: an outcome sink of the DetectionDirector that writes, per frame and
detector, the reason a detector found nothing (the ``reason`` its result carried), as text for a person or as JSON Lines
for a program. A detector that found objects in a frame writes nothing for it."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Protocol

from declare.parameters import printable

from .directors import DetectorOutcome
from .messages import Header

#: What is written for a detector that found nothing and gives no reason of its own.
NO_REASON = "no objects (this detector gives no reason)"


class TextOutput(Protocol):
    """Where reasons are written: a text stream, or anything that writes and flushes like one."""

    def write(self, text: str, /) -> int: ...

    def flush(self) -> None: ...


class ReasonSink:
    """Writes one line per detector that found nothing in a frame, flushed at once so that a person
    watching the stream sees it live.

    ``text``: ``frame 12: poster (FeatureDetector): too few matches: 6 of 10 needed``.
    ``jsonl``: ``{"seq", "stamp": {"secs", "nsecs"}, "detector", "type", "reason"}``.
    """

    FORMATS = ("text", "jsonl")

    def __init__(self, stream: TextOutput, format: str = "text") -> None:
        if format not in self.FORMATS:
            raise ValueError(f"format must be one of {', '.join(self.FORMATS)}, got {format!r}")
        self.stream = stream
        self.format = format
        #: Lines written so far.
        self.lines = 0

    def __call__(self, header: Header, outcomes: Sequence[DetectorOutcome]) -> None:
        lines = [self.line(header, o) for o in outcomes if o.found == 0]
        if not lines:
            return
        self.stream.write("".join(f"{line}\n" for line in lines))
        self.stream.flush()
        self.lines += len(lines)

    def line(self, header: Header, outcome: DetectorOutcome) -> str:
        reason = outcome.reason if outcome.reason is not None else NO_REASON
        if self.format == "text":  # control characters escaped: one reason, one line
            return f"frame {header.seq}: {printable(outcome.detector)} ({outcome.type_name}): {printable(reason, 2000)}"
        stamp = header.to_dict()["stamp"]
        return json.dumps({"seq": header.seq, "stamp": stamp, "detector": outcome.detector,
                           "type": outcome.type_name, "reason": reason}, separators=(",", ":"))
