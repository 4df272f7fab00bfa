"""A kind's first demo frames, made once per process and handed out as copies (a 3D demo frame takes most of
a second; a module that writes into its input must not spoil them for the next check)."""

from __future__ import annotations

import contextlib
import itertools
import threading
from typing import Any

from ..registry import get_kind, open_source

#: Frames taken from a kind's demo source when the caller gives none.
DEMO_FRAMES = 2

_cache: dict[tuple[str, str], list[Any]] = {}
_lock = threading.Lock()


def demo_frames(kind: str, spec: str | None = None) -> list[Any]:
    """Copies of the first ``DEMO_FRAMES`` frames' data of ``spec`` (the kind's ``demo_spec`` by default)."""
    kind_object = get_kind(kind)
    spec = kind_object.demo_spec if spec is None else spec
    with _lock:
        if (kind, spec) not in _cache:
            with contextlib.closing(open_source(spec, kind)) as source:
                _cache[kind, spec] = [f.data for f in itertools.islice(iter(source), DEMO_FRAMES)]
        frames = _cache[kind, spec]
    return [kind_object.copy_frame(f) for f in frames]
