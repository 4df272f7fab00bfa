"""Where detected objects go: JSON Lines (one array per line) or any callable."""

from __future__ import annotations

import io
import os
from typing import IO

from strictio import OutputError
from strictio.atomic import LineOutput

from .messages import DetectedObjectArray


def _line_output(stream: IO[str]) -> LineOutput | None:
    """The stream's file descriptor as a LineOutput, where it has one (not a StringIO or captured output)."""
    if isinstance(stream, LineOutput):
        return stream
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        return None
    return LineOutput(fd, str(getattr(stream, "name", "the output")), owned=False, flush_first=stream.flush)


class JSONLinesSink:
    """Writes one JSON object per frame at once, so a consumer reading a pipe sees it as it comes.

    Each line is written whole or not at all: a write failure (a full disk) is a ``strictio.OutputError``,
    and the file keeps only the complete lines before it. ``skip_empty`` leaves out frames where nothing was
    found.
    """

    def __init__(self, target: IO[str] | str | os.PathLike[str], skip_empty: bool = False) -> None:
        self._stream: IO[str] | None = None
        if isinstance(target, str | os.PathLike):
            self._lines = LineOutput.create(target)
            self._owned = True
        else:
            self._lines = _line_output(target)  # written past the stream's buffer, which stays empty
            self._stream = None if self._lines is not None else target
            self._owned = False
        self.skip_empty = skip_empty
        self.lines = 0

    def __call__(self, array: DetectedObjectArray) -> None:
        if self.skip_empty and not array.objects:
            return
        line = array.to_json() + "\n"
        if self._lines is not None:
            self._lines.write(line)
        else:
            assert self._stream is not None
            try:
                self._stream.write(line)
                self._stream.flush()
            except BrokenPipeError:
                raise
            except OSError as exc:
                raise OutputError(getattr(self._stream, "name", "the output"),
                                  f"cannot be written: {exc.strerror or exc}") from None
        self.lines += 1

    def close(self) -> None:
        """Close a file this sink opened (the stream it was given stays open for its owner)."""
        if self._lines is not None:
            if self._owned:
                self._lines.close()
        elif self._stream is not None:
            self._stream.flush()

    def __enter__(self) -> JSONLinesSink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
