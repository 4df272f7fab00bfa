"""A small event bus: everything that happens in a run, stamped with simulation time.

The state machine, move_base, batteries and docking all report here; the command writes it as JSON
Lines (``--events``), tests read it back, and the battery monitors subscribe to it the way ROS
smach monitors subscribed to ROS topics.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from strictio.atomic import LineOutput

log = logging.getLogger(__name__)

Event = dict[str, Any]
Listener = Callable[[Event], None]


class EventLog:
    """Collects events, hands each to subscribers and optionally streams them to a JSONL file."""

    def __init__(self, time_source: Callable[[], float], keep: bool = True) -> None:
        self._time = time_source
        self.keep = keep
        self.events: list[Event] = []
        self._listeners: list[Listener] = []
        self._stream: LineOutput | None = None

    def open(self, path: str | Path) -> None:
        """Stream every following event to ``path`` as one JSON object per line.

        Each line is written as it is emitted, so someone tailing the file during a real-time run sees each
        event as it happens; a write failure (a full disk) raises ``strictio.OutputError`` from ``emit``,
        the file keeping the whole lines before it, and the run's later events are kept in memory only.
        """
        self._stream = LineOutput.create(path)

    def close(self) -> None:
        """Close the events file; OutputError if its last bytes cannot be written (not a second time for a
        failure ``emit`` already raised)."""
        stream, self._stream = self._stream, None
        if stream is not None:
            stream.close()

    def subscribe(self, listener: Listener) -> Callable[[], None]:
        """Add a listener; returns the function that removes it again."""
        self._listeners.append(listener)

        def unsubscribe() -> None:
            if listener in self._listeners:
                self._listeners.remove(listener)

        return unsubscribe

    def emit(self, kind: str, **fields: Any) -> Event:
        event: Event = {"t": round(self._time(), 3), "type": kind, **fields}
        if self.keep:
            self.events.append(event)
        if self._stream is not None:
            stream = self._stream
            try:
                stream.write(json.dumps(event) + "\n")
            except BaseException:
                if stream.failed is not None:  # the file is done for; the run's end must not fail on it again
                    self._stream = None
                    stream.close()
                raise
        log.debug("event %s", event)
        for listener in list(self._listeners):
            listener(event)
        return event

    def of_type(self, kind: str) -> list[Event]:
        return [e for e in self.events if e["type"] == kind]
