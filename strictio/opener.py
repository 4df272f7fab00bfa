"""The one way the project opens an input file: regular files only, and never more bytes than a cap.

A FIFO would block forever, ``/dev/zero`` would fill memory, a directory gives a confusing error later:
each is refused here with the file's name. The cap is per call (a parameter file is small, a video is not).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import BinaryIO

from .errors import InputError

#: Default cap on what one read takes: 64 MiB (a parameter file with an embedded target is ~200 KB).
DEFAULT_LIMIT = 64 * 1024 * 1024


def describe_mode(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def open_input(path: str | os.PathLike[str], limit: int | None = DEFAULT_LIMIT) -> BinaryIO:
    """Open ``path`` for reading in binary, after checking that it is a regular file of at most ``limit``
    bytes (``None``: no cap, for files read in pieces such as videos).

    The file is opened with ``O_NONBLOCK`` so that a FIFO swapped in after the check cannot block, and the
    check is made again on the open descriptor.
    """
    shown = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise InputError(shown, "file not found") from None
    except IsADirectoryError:
        raise InputError(shown, "is a folder, not a file") from None
    except OSError as exc:
        raise InputError(shown, f"cannot be opened: {exc.strerror or exc}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise InputError(shown, f"is {describe_mode(info.st_mode)}, not a regular file")
        if limit is not None and info.st_size > limit:
            raise InputError(
                shown, f"is {info.st_size:,} bytes, over the limit of {limit:,} bytes for this kind of file"
            )
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_bytes(path: str | os.PathLike[str], limit: int = DEFAULT_LIMIT) -> bytes:
    """The whole content of a regular file of at most ``limit`` bytes (it may not grow past it meanwhile)."""
    with open_input(path, limit) as stream:
        try:
            data = stream.read(limit + 1)
        except OSError as exc:
            raise InputError(path, f"cannot be read: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise InputError(path, f"grew past the limit of {limit:,} bytes while it was read")
    return data


def read_text(path: str | os.PathLike[str], limit: int = DEFAULT_LIMIT, encoding: str = "utf-8") -> str:
    """Text of a regular file; a UTF-8 byte-order mark is dropped, undecodable bytes are an InputError."""
    data = read_bytes(path, limit)
    if encoding.lower().replace("-", "") == "utf8" and data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        bad = data[exc.start : exc.start + 1]
        raise InputError(path, f"is not {encoding} text (byte {exc.start}: {bad!r})") from None


def is_regular_file(path: str | os.PathLike[str]) -> bool:
    """True for an existing regular file (following links)."""
    try:
        return stat.S_ISREG(Path(path).stat().st_mode)
    except OSError:
        return False
