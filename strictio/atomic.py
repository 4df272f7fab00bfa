"""Saving so that a reader, or a crash, sees the old file or the new one, never half of either."""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path

from .errors import OutputError


def write_atomically(path: str | os.PathLike[str], data: str | bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and ``os.replace``.

    A link keeps pointing at the file it shares (the link's target is replaced). What exists at the path
    and is not a regular file (a FIFO, a device) is refused rather than replaced, and so is a read-only file.
    """
    shown = str(path)
    target = Path(os.path.realpath(path))
    folder = target.parent
    if not folder.is_dir():
        raise OutputError(shown, f"cannot save: folder {Path(shown).parent} does not exist")
    try:
        info = target.stat()
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise OutputError(shown, f"cannot save: {exc.strerror or exc}") from None
    if info is not None:
        if not stat.S_ISREG(info.st_mode):
            raise OutputError(shown, "cannot save: it exists and is not a regular file")
        if not os.access(target, os.W_OK):
            raise OutputError(shown, "cannot save: the file is read-only")
    tmp_name = ""
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
        with os.fdopen(fd, "wb") as stream:
            stream.write(data.encode("utf-8") if isinstance(data, str) else data)
            stream.flush()
            os.fsync(stream.fileno())
        os.chmod(tmp_name, (info.st_mode & 0o777) if info is not None else 0o644)
        os.replace(tmp_name, target)
        tmp_name = ""
    except OSError as exc:
        raise OutputError(shown, f"cannot save: {exc.strerror or exc}") from None
    finally:
        if tmp_name:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)
