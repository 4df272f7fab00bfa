"""Where detected objects go: JSON Lines (one array per line) or any callable."""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO

from .messages import DetectedObjectArray


class JSONLinesSink:
    """Writes one JSON object per frame and flushes it, so a consumer reading a pipe sees it at once.

    ``skip_empty`` leaves out frames where nothing was found.
    """

    def __init__(self, target: IO[str] | str | os.PathLike[str], skip_empty: bool = False) -> None:
        if isinstance(target, str | os.PathLike):
            self._stream: IO[str] = Path(target).open("w", encoding="utf-8")  # noqa: SIM115 - closed by close()
            self._owned = True
        else:
            self._stream = target
            self._owned = False
        self.skip_empty = skip_empty
        self.lines = 0

    def __call__(self, array: DetectedObjectArray) -> None:
        if self.skip_empty and not array.objects:
            return
        self._stream.write(array.to_json() + "\n")
        self._stream.flush()
        self.lines += 1

    def close(self) -> None:
        if self._owned:
            self._stream.close()
        else:
            self._stream.flush()

    def __enter__(self) -> JSONLinesSink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
