"""Writing so that a reader, or a crash, sees whole things: the old file or the new one, whole lines.

A save (:func:`write_atomically`) writes a temporary file next to the target and renames it over the
target. The temporary's name carries the saving machine and process id
(``.NAME.saving-HOST-PID-XXXXXXXX.tmp``), so the temporaries of a save that was killed are recognised and
removed by the next save into that folder (:func:`remove_stale_temporaries`), while those of a save still
running, here or on another machine sharing the folder, are left alone.

A streamed text output (JSON Lines, reasons, events) goes through :class:`LineOutput`: it writes whole lines
only, and when the disk fills up in the middle of one it cuts the file back to the end of the last whole line,
so what a failed run leaves is every line it wrote before, each one complete.

Text is written as UTF-8; a lone surrogate (a name with bytes that are not UTF-8) is written as its escape
(:func:`strictio.shown.valid_text`), so every text file the project writes is valid UTF-8.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import socket
import stat
from collections.abc import Callable
from pathlib import Path

from .errors import OutputError
from .opener import describe_mode
from .output_paths import is_open_descriptor
from .shown import valid_text

_TEMPORARY = re.compile(r"\..+\.saving-(?P<host>[A-Za-z0-9-]+)-(?P<pid>\d+)-[0-9a-f]{8}(\.[A-Za-z0-9]{1,8})?")
#: This machine's name as temporaries carry it: a folder shared over the network holds the temporaries of
#: other machines' savers, whose process ids mean nothing here.
_HOST = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname())[:40] or "host"


def temporary_path(target: Path, suffix: str = ".tmp") -> Path:
    """A new name for a temporary next to ``target``, recognisable as this process's (see the module doc);
    ``suffix`` ``.avi`` for a writer that chooses the format by it."""
    return target.with_name(f".{target.name}.saving-{_HOST}-{os.getpid()}-{secrets.token_hex(4)}{suffix}")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):  # another user's process: alive; an absurd pid: not ours to judge
        return True
    return True


def remove_stale_temporaries(folder: str | os.PathLike[str]) -> int:
    """Remove the temporaries (files or folders) that saves of processes no longer running left in ``folder``.

    Only this machine's are judged. A process id reused by a new process keeps its old temporary until that
    process ends too: leaving one file a while longer is better than deleting a save in progress. Returns
    how many were removed.
    """
    removed = 0
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return 0
    for entry in entries:
        found = _TEMPORARY.fullmatch(entry.name) if entry.name.startswith(".") and ".saving-" in entry.name else None
        if found is None or found["host"] != _HOST or _alive(int(found["pid"])):
            continue
        try:
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
            removed += 1
        except OSError:
            continue  # someone else removed it, or it is not ours to remove
    return removed


def is_read_only(path: str | os.PathLike[str], info: os.stat_result) -> bool:
    """Whether a file is meant not to be written: no write permission bit at all (which root would ignore),
    or none for this user."""
    return not info.st_mode & 0o222 or not os.access(path, os.W_OK)


def check_replaceable(shown: str, target: Path) -> os.stat_result | None:
    """The target's status if a save may replace it, None if it does not exist yet; OutputError for what
    must stay as it is (a FIFO, a device, a folder, a read-only file)."""
    try:
        info = target.stat()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise OutputError(shown, f"cannot save: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise OutputError(shown, f"cannot save: it is {describe_mode(info.st_mode)}, not a regular file; "
                                 "it is left as it is")
    if is_read_only(target, info):
        raise OutputError(shown, "cannot save: the file is read-only")
    return info


def _check_streamable(shown: str, target: Path) -> None:
    """What a stream of lines may not be opened on: a read-only file (by its mode bits: root too), a FIFO (the
    open would wait for a reader for ever), a socket or a block device. A character device (a terminal,
    ``/dev/null``) is a stream's fair target."""
    try:
        info = target.stat()
    except OSError:
        return  # missing: created; unreachable: the open says why
    if stat.S_ISREG(info.st_mode):
        if not info.st_mode & 0o222:
            raise OutputError(shown, "cannot be written: the file is read-only")
    elif not stat.S_ISCHR(info.st_mode) and not is_open_descriptor(shown):
        raise OutputError(shown, f"cannot be written: it is {describe_mode(info.st_mode)}, not a regular file")


def write_atomically(path: str | os.PathLike[str], data: str | bytes, *, durable: bool = True) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and ``os.replace``.

    A link keeps pointing at the file it shares (the link's target is replaced). What exists at the path
    and is not a regular file (a FIFO, a device, a folder) is refused rather than replaced, and so is a
    read-only file. ``durable`` waits for the disk (fsync) before the rename; a file rewritten many times a
    second for a viewer (a live diagram) can skip that. Every failure is an OutputError; the old file stays.
    """
    shown = str(path)
    target = Path(os.path.realpath(path))
    folder = target.parent
    if not folder.is_dir():
        raise OutputError(shown, f"cannot save: folder {Path(shown).parent} does not exist")
    info = check_replaceable(shown, target)
    remove_stale_temporaries(folder)
    temporary = temporary_path(target)
    created = False
    try:
        fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
        created = True
        with os.fdopen(fd, "wb") as stream:
            stream.write(valid_text(data).encode("utf-8") if isinstance(data, str) else data)
            stream.flush()
            if durable:
                os.fsync(stream.fileno())
        os.chmod(temporary, stat.S_IMODE(info.st_mode) if info is not None else 0o644)
        os.replace(temporary, target)
        created = False
    except OSError as exc:
        raise OutputError(shown, f"cannot save: {exc.strerror or exc}") from None
    finally:
        if created:
            with contextlib.suppress(OSError):
                os.unlink(temporary)


class LineOutput:
    """A text output that receives whole lines or nothing: a write failure (a full disk, a file size limit, a
    closed device) is an OutputError, and a line cut short is taken back out of the file.

    Text is passed on at each newline, so a person following the file sees every line at once. Give it a
    path (:meth:`create`) or the descriptor of an open stream (``flush_first``: that stream's own ``flush``,
    called before each write so lines written through either stay in order).
    """

    def __init__(self, fd: int, shown: str, *, owned: bool, flush_first: Callable[[], None] | None = None) -> None:
        self.fd = fd
        self.name = shown
        self.lines = 0
        self._owned = owned
        self._flush_first = flush_first
        self._pending = ""
        self._failure: OutputError | None = None
        self.closed = False
        try:
            self._seekable = stat.S_ISREG(os.fstat(fd).st_mode)  # a pipe or a terminal: nothing to cut back
        except OSError:
            self._seekable = False

    @classmethod
    def create(cls, path: str | os.PathLike[str], make_folders: bool = False) -> LineOutput:
        """Create (or empty) the file at ``path`` (``make_folders``: its missing parent folders made first);
        OutputError if it cannot be."""
        shown = str(path)
        target = Path(path)
        try:
            if target.is_dir():
                raise OutputError(shown, "cannot be written: it is a folder")
            if make_folders:
                target.parent.mkdir(parents=True, exist_ok=True)
            _check_streamable(shown, target)
            # O_NONBLOCK: a FIFO swapped in after the check fails to open (no reader) rather than blocking for ever
            fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_CLOEXEC", 0)
                         | getattr(os, "O_NONBLOCK", 0), 0o666)
        except OutputError:
            raise
        except OSError as exc:
            raise OutputError(shown, f"cannot be written: {exc.strerror or exc}") from None
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return cls(fd, shown, owned=True)

    @property
    def failed(self) -> OutputError | None:
        """The write failure this output ended with, if any."""
        return self._failure

    def fileno(self) -> int:
        return self.fd

    def writable(self) -> bool:
        return not self.closed

    def write(self, text: str) -> int:
        """Take ``text``; the lines it completes are written at once, whole."""
        if self._failure is not None:
            raise self._failure
        if self.closed:
            raise OutputError(self.name, "cannot be written: it is closed")
        self._pending += text
        end = self._pending.rfind("\n") + 1
        if end:
            lines, self._pending = self._pending[:end], self._pending[end:]
            self._put(valid_text(lines).encode("utf-8"))
            self.lines += lines.count("\n")
        return len(text)

    def flush(self) -> None:
        """Lines are written as they complete; an unfinished one waits for its newline (or ``close``)."""
        if self._failure is not None:
            raise self._failure

    def close(self) -> None:
        """Write an unfinished last line, then close; a failure of either is an OutputError (raised once)."""
        if self.closed:
            return
        self.closed = True
        try:
            if self._pending and self._failure is None:
                pending, self._pending = self._pending, ""
                self._put(valid_text(pending).encode("utf-8"))
        finally:
            if self._owned:
                try:
                    os.close(self.fd)
                except OSError as exc:
                    if self._failure is None:
                        raise OutputError(self.name, f"cannot be written: {exc.strerror or exc}") from None

    def _put(self, data: bytes) -> None:
        """Write ``data`` (whole lines) to the end; on any failure cut the file back to the last whole line."""
        if self._flush_first is not None:
            self._flush_first()
        whole_end = self._position()
        view = memoryview(data)
        try:
            while view:
                view = view[os.write(self.fd, view):]
        except BrokenPipeError:
            raise  # the reader went away (``| head``): the commands end quietly, not with an error
        except BaseException as exc:
            self._cut_back(whole_end)
            if not isinstance(exc, OSError):
                raise  # an interrupt: the file is whole again, the interrupt goes on
            kept = "1 whole line before it is" if self.lines == 1 else f"{self.lines} whole lines before it are"
            self._failure = OutputError(self.name, f"cannot be written: {exc.strerror or exc}; {kept} kept")
            raise self._failure from None

    def _position(self) -> int | None:
        if not self._seekable:
            return None
        try:
            return os.lseek(self.fd, 0, os.SEEK_CUR)
        except OSError:
            return None

    def _cut_back(self, whole_end: int | None) -> None:
        if whole_end is None:
            return
        with contextlib.suppress(OSError):
            os.ftruncate(self.fd, whole_end)
            os.lseek(self.fd, whole_end, os.SEEK_SET)

    def __enter__(self) -> LineOutput:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
