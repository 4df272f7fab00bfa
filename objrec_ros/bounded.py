"""Bounded decompression for recordings: no chunk, message or file of a recording inflates past a declared limit.

rosbags inflates a ROS 1 chunk (bz2, lz4), an MCAP chunk (zstd, lz4), a ROS 2 per-message zstd payload and a
file-compressed ROS 2 storage file with the libraries' one-shot calls, which allocate whatever the compressed
bytes expand to: a few kilobytes of zeros become gigabytes before anything can look at them. rosbags looks
its decompressors up at call time in module tables, so :func:`install` replaces those entries with the
streaming ones here, which ask for at most the limit plus one byte and refuse the rest:

- a size the container declares (an MCAP chunk's ``uncompressed_size``) is checked against the limit before
  inflating, and the output must not exceed it (never trusted alone: the output is bounded either way);
- a ROS 1 chunk and a per-message payload declare nothing usable, so the limit alone bounds them;
- a file-compressed ROS 2 storage file is expanded into the temp folder: :func:`check_temp_space` checks
  what its zstd frames declare against :data:`RECORDING_TEMP_BYTES` and the folder's free space first, and
  the copy stops at that budget.

Every reader of recordings goes through :func:`install` (``objrec_ros.bags`` when a recording is opened,
``objrec_ros.output`` when one is copied), so ``--list-topics``, batch and the GUI are bounded alike. A
refusal is an :class:`InflateError` (a ``strictio.LimitError``): the limit, the amount and how to raise it.
"""

from __future__ import annotations

import bz2
import logging
import shutil
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any, BinaryIO

from strictio import InputError, LimitError
from strictio.limits import RECORDING_CHUNK_BYTES, RECORDING_TEMP_BYTES, Limit

log = logging.getLogger(__name__)

#: What a decompressor object offers: ``decompress(data, max_length)``, ``eof``, ``unused_data``.
Decompressor = Any
_installed = False
_lock = threading.Lock()


class InflateError(LimitError):
    """Compressed data of a recording that would inflate past a limit, or past what its container declares."""

    def __init__(self, limit: Limit, claimed: int, what: str) -> None:
        super().__init__("recording", limit, claimed, what)

    def __str__(self) -> str:  # rosbags' callers show str(exc): the part after the (unknown here) file name
        return self.message


class DeclaredSizeError(ValueError):
    """Compressed data that inflates to more than the size its container declares (corrupt or hostile)."""


def _zstd() -> Any:
    try:
        from compression import zstd  # type: ignore[import-not-found]  # Python 3.14
    except ImportError:
        from backports import zstd  # type: ignore[import-not-found,no-redef]
    return zstd


def _lz4() -> Decompressor:
    from lz4.frame import LZ4FrameDecompressor  # type: ignore[import-untyped]

    return LZ4FrameDecompressor()


#: A fresh streaming decompressor per codec name (the names rosbags and the formats use).
CODECS: dict[str, Callable[[], Decompressor]] = {
    "bz2": bz2.BZ2Decompressor,
    "lz4": _lz4,
    "zstd": lambda: _zstd().ZstdDecompressor(),
}


def inflate(data: bytes | memoryview, codec: str, *, declared: int | None = None,
            limit: Limit = RECORDING_CHUNK_BYTES, what: str = "") -> bytes:
    """``data`` decompressed with ``codec`` (bz2, lz4, zstd; concatenated frames or streams too), never more
    than ``limit`` allows nor more than ``declared`` (the size its container states, when it states one).

    The limit is checked against ``declared`` before anything is inflated; the output is then produced with a
    maximum length, so a bomb costs the limit plus one byte at most, not what it expands to."""
    what = what or f"{codec} data"
    bound = limit.value()
    if declared is not None and declared > bound:
        raise InflateError(limit, declared, f"{what}, declared")
    framed = zstd_declared(data) if codec == "zstd" else None
    if framed is not None and framed > bound:  # what its frames declare: refused before inflating any
        raise InflateError(limit, framed, f"{what}, its frames declare")
    cap = bound if declared is None else declared
    parts: list[bytes] = []
    total = 0
    rest: bytes | memoryview = data
    while True:
        decompressor = CODECS[codec]()
        part = decompressor.decompress(rest, cap - total + 1)
        total += len(part)
        parts.append(part)
        if total > cap:
            if declared is not None and declared < bound:
                raise DeclaredSizeError(f"{what} inflates to more than the {declared:,} bytes it declares")
            raise InflateError(limit, total, f"{what}, inflated")
        if not decompressor.eof:
            raise DeclaredSizeError(f"{what} is truncated (the compressed stream ends early)")
        rest = decompressor.unused_data
        if not rest:
            break
    return parts[0] if len(parts) == 1 else b"".join(parts)


def zstd_declared(data: bytes | memoryview, max_frames: int = 4096) -> int | None:
    """The uncompressed size zstd ``data``'s frames declare in all (their headers only, nothing inflated), or
    None when a frame does not declare its size (or the data is not whole frames): then only the limit bounds
    it while inflating."""
    zstd = _zstd()
    view = memoryview(data)
    total, offset = 0, 0
    try:
        for _ in range(max_frames):
            if offset >= len(view):
                return total
            size = zstd.get_frame_info(view[offset:offset + 18]).decompressed_size
            if size is None:
                return None
            total += size
            offset += zstd.get_frame_size(view[offset:])
    except Exception:  # not a zstd frame, or a cut one: inflating says what is wrong
        return None
    return None


# -- ROS 2 file compression: the temp space first ------------------------------------------------------------
def temp_folder() -> Path:
    return Path(tempfile.gettempdir())


def declared_file_size(path: Path) -> int | None:
    """The uncompressed size a zstd-compressed storage file's first frame declares, or None when it does not
    say (a streamed frame) or the file is not zstd."""
    try:
        with path.open("rb") as stream:
            head = stream.read(18)
        return _zstd().get_frame_info(head).decompressed_size
    except Exception:  # not a zstd frame: rosbags will say so when it reads it
        return None


def temp_budget() -> int:
    """Bytes a file-compressed ROS 2 bag may expand into the temp folder: the limit, or the folder's free space
    less a margin of 64 MiB when that is smaller."""
    try:
        free = shutil.disk_usage(temp_folder()).free
    except OSError:
        free = 0
    return max(0, min(RECORDING_TEMP_BYTES.value(), free - (64 << 20)))


def inflated_size(path: Path, cap: int) -> int:
    """How many bytes a zstd-compressed storage file inflates to, counted by streaming it (nothing kept, nothing
    written), up to ``cap + 1``: what a frame header declares may be absent or a lie."""
    total = 0
    with path.open("rb") as raw, _zstd().open(raw, "rb") as stream:
        while total <= cap:
            block = stream.read(min(1 << 20, cap + 1 - total))
            if not block:
                break
            total += len(block)
    return total


def check_temp_space(files: list[Path]) -> int:
    """The temp space a file-compressed ROS 2 bag needs (its storage files inflated), checked before anything
    is written there: refused past :data:`RECORDING_TEMP_BYTES` or past the temp folder's free space.

    A size a frame declares beyond the limit is refused at once; otherwise the files are inflated once without
    keeping anything (decompression is fast, a full disk is not), so a frame that lies is counted too."""
    limit = RECORDING_TEMP_BYTES.value()
    declared = sum(d for d in (declared_file_size(f) for f in files) if d)
    if declared > limit:
        raise InflateError(RECORDING_TEMP_BYTES, declared, "its compressed storage files, declared")
    need = 0
    for file in files:
        need += inflated_size(file, limit - need)
        if need > limit:
            raise InflateError(RECORDING_TEMP_BYTES, need, "its compressed storage files, inflated")
    budget = temp_budget()
    if need > budget:
        raise InputError("recording", f"its storage files inflate to {need:,} bytes, more than the {budget:,} "
                                      f"bytes free in {temp_folder()} less a margin (set TMPDIR to a folder with "
                                      "more room)")
    return need


class _BoundedFile:
    """A read-only stream over a zstd file that refuses to give more than ``budget`` bytes in all."""

    def __init__(self, raw: BinaryIO, budget: int) -> None:
        self._stream = _zstd().open(raw, "rb")
        self._left = budget
        self._budget = budget

    def read(self, size: int = -1) -> bytes:
        want = 1 << 20 if size is None or size < 0 else size
        data = self._stream.read(min(want, self._left + 1))
        self._left -= len(data)
        if self._left < 0:
            raise InflateError(RECORDING_TEMP_BYTES, self._budget + 1,
                               f"a compressed storage file inflates past the {self._budget:,} bytes allowed in "
                               f"{temp_folder()}, at least")
        return data

    def __enter__(self) -> _BoundedFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self._stream.close()


# -- the replacements in rosbags ------------------------------------------------------------------------------
def _ros1_chunk(codec: str) -> Callable[[bytes], bytes]:
    return lambda data: inflate(data, codec, what=f"a {codec} chunk")


def _read_ros1_chunk(self: Any) -> Any:
    """rosbags' ``Reader.read_chunk`` with the chunk's declared uncompressed ``size`` kept: its inflation is
    checked against that size (and the limit) before anything is inflated, and bounded by it while inflating."""
    import os

    from rosbags.rosbag1 import reader as ros1

    header = ros1.Header.read(self.bio, ros1.RecordType.CHUNK)
    compression = header.get_string("compression")
    size = header.get_uint32("size")
    datasize = ros1.read_uint32(self.bio)
    datapos = self.bio.tell()
    self.bio.seek(datasize, os.SEEK_CUR)
    if compression not in ros1.decompressors:
        raise ros1.ReaderError(f"Compression {compression!r} is not supported.")
    if compression == "none":
        decompressor = ros1.decompressors["none"]  # the identity, which objrec_ros.direct recognises
    else:
        def decompressor(data: bytes) -> bytes:
            return inflate(data, compression, declared=size, what=f"a {compression} chunk")
    return ros1.Chunk(datasize, datapos, decompressor)


def _mcap_chunk(codec: str) -> Callable[[bytes, int], bytes]:
    return lambda data, size: inflate(data, codec, declared=size, what=f"a {codec} chunk")


def install() -> None:
    """Replace rosbags' decompression with the bounded one (once per process; safe from any thread)."""
    global _installed
    with _lock:
        if _installed:
            return
        from rosbags.rosbag1 import reader as ros1
        from rosbags.rosbag2 import reader as ros2
        from rosbags.rosbag2 import storage_mcap

        for codec in ("bz2", "lz4"):
            if codec in ros1.decompressors:
                ros1.decompressors[codec] = _ros1_chunk(codec)
        if all(hasattr(ros1, name) for name in ("Header", "RecordType", "Chunk", "read_uint32", "ReaderError")):
            ros1.Reader.read_chunk = _read_ros1_chunk  # type: ignore[method-assign]
        for codec in ("lz4", "zstd"):
            if codec in storage_mcap.DECOMPRESSORS:
                storage_mcap.DECOMPRESSORS[codec] = _mcap_chunk(codec)
        ros2.zstd = SimpleNamespace(  # type: ignore[attr-defined]
            decompress=lambda data: inflate(data, "zstd", what="a zstd-compressed message"),
            open=lambda raw, mode="rb": _BoundedFile(raw, temp_budget()),
        )
        _installed = True
        log.debug("rosbags' decompression bounded (%s, temp %s)", RECORDING_CHUNK_BYTES.variable,
                  RECORDING_TEMP_BYTES.variable)
