"""The files a detection run reads, named for the output-path rule (:class:`strictio.output_paths.RunFiles`).

A source is a spec, not always a path: ``bag:PATH,topic=/x``, ``rgbd:COLOR,DEPTH``. Every part of it that
names an existing file or folder is an input, whichever source type reads it, so an output can be checked
against the source before the source is opened and before anything is written.
"""

from __future__ import annotations

import os
from pathlib import Path

from strictio.output_paths import RunFiles

#: Source options whose values name files (``bag:path=...``, ``rgbd:color=...,depth=...,intrinsics=...``).
PATH_OPTIONS = frozenset({"path", "color", "depth", "intrinsics"})
#: Source options whose values name files the source writes (``demo:truth=FILE``: the truth of each frame).
OUTPUT_OPTIONS = frozenset({"truth"})
#: Schemes whose parts are topics and addresses, never files (``ros1:/camera,master=http://...``).
LIVE_SCHEMES = frozenset({"ros1", "ros2"})


def source_paths(text: str | None) -> list[Path]:
    """The files and folders a source spec names (none for ``demo``, ``camera:0``, a live topic): the spec
    itself where it is a path, else each positional part after the scheme and each value of a path option
    (:data:`PATH_OPTIONS`) that exists.

    Parsed without the source registry, so that judging the outputs imports no kind that the run's own kind
    does not need; a part that merely happens to name an existing file is only protected the more.
    """
    if not text:
        return []
    named = [text]
    scheme, colon, rest = text.partition(":")
    if colon and scheme.strip().lower() not in LIVE_SCHEMES:
        for part in rest.split(","):
            key, equals, value = part.partition("=")
            if not equals:
                named.append(part)
            elif key.strip() in PATH_OPTIONS:
                named.append(value)
    paths = [Path(p.strip()).expanduser() for p in named if p.strip()]
    return [p for p in paths if os.path.lexists(p)]


def source_outputs(text: str | None) -> list[tuple[str, str]]:
    """The files a source spec asks the source to write, as (option, path): ``demo:truth=out.json``."""
    scheme, colon, rest = (text or "").partition(":")
    if not colon or scheme.strip().lower() in LIVE_SCHEMES:
        return []
    found = []
    for part in rest.split(","):
        key, equals, value = part.partition("=")
        if equals and key.strip() in OUTPUT_OPTIONS and value.strip():
            found.append((f"{key.strip()}= of --source", value.strip()))
    return found


def detection_inputs(params: str | None, source: str | None) -> RunFiles:
    """A detection run's inputs: its parameter file and every file or folder its source names."""
    files = RunFiles().reads(params, "the parameter file")
    for path in source_paths(source):
        files.reads(path, "the source")
    return files
