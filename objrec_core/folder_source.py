"""Sources named by a path whose frames are files: one file, or every file of a folder, for any kind.

A kind's folder source says only which extensions it reads, what its files are called in messages and how one
file is read (:meth:`FolderFilesSource.read_file`); listing, natural sorting, seeking, the length, skipping a
file that cannot be read with one warning, and the error when none can, are here once, so that a folder of
images and a folder of point clouds behave alike. Nothing here reads a file's contents: OpenCV, Open3D or NumPy
stay in the kinds.
"""

from __future__ import annotations

import logging
import re
from abc import abstractmethod
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

from strictio import InputError

from .sources import Frame, FrameSource, SourceError, SourceSpec

log = logging.getLogger(__name__)


def natural_key(path: Path) -> list[object]:
    """frame2.png before frame10.png, case aside."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def file_stamp(path: Path) -> float:
    """When the file was written (0 when it went away meanwhile)."""
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0


class PathSource(FrameSource):
    """A source named by a path, of known length, whose frames can start anywhere (:meth:`frames_from`)."""

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> PathSource:
        return cls(spec.path if spec.path is not None else Path(spec.text), name=spec.text)

    @property
    def seekable(self) -> bool:
        return True

    def __iter__(self) -> Iterator[Frame]:
        return self.frames_from(0)

    @abstractmethod
    def frames_from(self, index: int) -> Iterator[Frame]: ...


class FolderFilesSource(PathSource):
    """Every file of a folder with one of ``extensions``, in natural name order, one frame each; or one file.

    In a folder, a file that cannot be read (an ``InputError`` from :meth:`read_file`) is reported in one
    warning naming it and why, and skipped; only when none of them could be read is that a SourceError. One
    file given alone that cannot be read is an error at once.
    """

    folders = True
    #: The suffixes of the files read (lower case); by default the ``extensions`` the source is chosen by.
    file_suffixes: ClassVar[tuple[str, ...]] = ()
    #: What the files are called in messages, plural ("images", "point-cloud files").
    what: ClassVar[str] = "files"
    #: The error when no file of the folder could be read.
    none_readable: ClassVar[str] = "{name}: none of its {count} {what} could be read"

    def __init__(self, path: str | Path, name: str | None = None) -> None:
        suffixes = self.file_suffixes or self.extensions
        self.path = Path(path)
        self.name = name if name is not None else str(path)
        self.folder = self.path.is_dir()
        if self.folder:
            try:
                entries = list(self.path.iterdir())
            except OSError as exc:
                raise SourceError(f"{self.name}: cannot list the folder: {exc.strerror or exc}") from None
            self.files = sorted((p for p in entries if p.suffix.lower() in suffixes and not p.is_dir()),
                                key=natural_key)
            if not self.files:
                raise SourceError(f"{self.name}: folder holds no {self.what} ({', '.join(sorted(suffixes))})")
        elif not self.path.exists():
            raise SourceError(f"{self.name}: no such file or folder")
        elif self.path.suffix.lower() not in suffixes:  # a FIFO or a device is refused by the reader
            raise SourceError(f"{self.name}: {self.what} end in {', '.join(sorted(suffixes))}")
        else:
            self.files = [self.path]
        #: The files of a folder that could not be read, in the order they were met.
        self.skipped: list[Path] = []

    @classmethod
    @abstractmethod
    def read_file(cls, path: Path) -> Any:
        """One file's frame data; InputError naming the file when it cannot be read."""

    @property
    def length(self) -> int:
        return len(self.files)

    def frames_from(self, index: int) -> Iterator[Frame]:
        """From the ``index``-th file on; each frame's ``source`` is its file, so a viewer can name it."""
        start = max(0, index)
        read = 0
        for number, path in enumerate(self.files[start:], start):
            if not self.folder:
                yield Frame(self.read_file(path), file_stamp(path), number, str(path))
                continue
            try:
                data = self.read_file(path)
            except InputError as exc:  # a reader's refusal and a limit's LimitError alike
                log.warning("%s; skipped", exc)
                if path not in self.skipped:
                    self.skipped.append(path)
                continue
            read += 1
            yield Frame(data, file_stamp(path), number, str(path))
        if self.folder and read == 0 and len(self.skipped) == len(self.files):
            raise SourceError(self.none_readable.format(name=self.name, count=len(self.files), what=self.what))
