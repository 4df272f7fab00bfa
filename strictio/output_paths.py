"""The one rule for where a run may write: never over what it reads, never out of its folder, never over what
must stay as it is. Judged before anything is written.

A run names every file it reads (:meth:`RunFiles.reads`: the parameter file, the source, a pose, world or
mission file, a recording; a folder source or a ROS 2 bag folder with every file in it) and then every path it
will write (:meth:`RunFiles.writes`, per option). An output is refused, with one line naming the option, the
path and why, when

- it is one of the inputs: the same path, the same file through a symbolic link or a hard link (same device
  and inode), or it lies inside an input folder (a folder source would read it back, a bag folder is
  replaced);
- it is a folder the run writes files into and it already holds one of the inputs (``objrec-batch --format
  mcap`` into the folder of the source ``.mcap``);
- through links it leaves the folder it belongs to (``inside``: a per-source file of ``--out`` that is a link
  to a file elsewhere);
- it exists and is read-only by its mode bits (no write bit at all: refused for root too, who would be let
  through by ``access()``), or its existing folder is;
- it is also the path of another output of the run;
- it exists and is not a regular file (a FIFO would block the run for ever; a socket, a block device, a
  folder where a file is meant); a character device (``/dev/null``, a terminal) only where the output is a
  stream of lines (``stream=True``), which may also be a descriptor the process holds (``/dev/stderr``).

The refusal is an :class:`OutputError` (one line, exit code 2 in every command).
"""

from __future__ import annotations

import fnmatch
import os
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from .errors import OutputError
from .opener import describe_mode

__all__ = ["MAX_FOLDER_FILES", "RunFiles", "is_open_descriptor", "read_only_by_mode"]

#: Paths of a descriptor the process holds already (``--explain=/dev/stderr``).
_DESCRIPTORS = ("/dev/stdout", "/dev/stderr", "/dev/fd/", "/proc/self/fd/")
_Refusal = Callable[[str], OutputError]

#: How many files of one input folder are remembered one by one (a folder source of a million pictures is
#: still protected as a whole: nothing may be written inside it).
MAX_FOLDER_FILES = 100_000


def read_only_by_mode(info: os.stat_result) -> bool:
    """No write permission bit at all: meant not to be written, whoever runs (root ignores the bits)."""
    return not info.st_mode & 0o222


def _real(path: str | os.PathLike[str]) -> Path:
    return Path(os.path.realpath(os.path.abspath(path)))


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or path.is_relative_to(folder)


@dataclass
class _Input:
    shown: str
    what: str
    real: Path
    folder: bool


@dataclass
class RunFiles:
    """What one run reads, and the judge of every path it is about to write.

    Name the inputs first (:meth:`reads`), then each output (:meth:`writes`, which refuses at once); an
    output found later in the run (a report named after a task) is judged the same way when it is found.
    """

    _inputs: list[_Input] = field(default_factory=list)
    _inodes: dict[tuple[int, int], _Input] = field(default_factory=dict)
    _outputs: dict[Path, str] = field(default_factory=dict)

    def reads(self, path: str | os.PathLike[str] | None, what: str = "an input") -> RunFiles:
        """Record that the run reads ``path``: a file, or a folder with every file in it (``what`` says what it is
        in the refusal: "the source", "the parameter file"). A missing path or None is ignored (the reader will
        say so); returns self, so that calls chain."""
        if path is None or str(path) == "":
            return self
        shown = os.fsdecode(path)
        real = _real(path)
        try:
            info = os.stat(real)
        except (OSError, ValueError):
            return self
        entry = _Input(shown, what, real, stat.S_ISDIR(info.st_mode))
        self._inputs.append(entry)
        self._inodes.setdefault((info.st_dev, info.st_ino), entry)
        if entry.folder:
            self._remember_files(real, entry)
        return self

    def _remember_files(self, folder: Path, entry: _Input) -> None:
        """Every file of an input folder by its inode, so that a hard link to one elsewhere is known too."""
        seen = 0
        for root, folders, files in os.walk(folder):
            folders.sort()
            for name in files:
                seen += 1
                if seen > MAX_FOLDER_FILES:
                    return
                try:
                    info = os.stat(os.path.join(root, name))
                except OSError:
                    continue
                member = _Input(os.path.join(root, name), f"a file of {entry.what} ({entry.shown})", Path(root, name),
                                False)
                self._inodes.setdefault((info.st_dev, info.st_ino), member)

    @property
    def inputs(self) -> list[str]:
        """The inputs named so far, as given."""
        return [entry.shown for entry in self._inputs]

    def writes(self, option: str, path: str | os.PathLike[str] | None, *, folder: bool = False,
               inside: str | os.PathLike[str] | None = None, stream: bool = False, names: str | None = "*") -> None:
        """Refuse (OutputError) to write ``path`` for ``option`` where the rule of the module forbids it.

        ``folder``: the output is a folder the run makes or fills (a ROS 2 bag, a folder of pictures), whose
        files match ``names`` (a glob: ``frame_*.png``; None where each file it writes is judged on its own).
        ``inside``: the folder this output belongs to, which it may not leave through links. ``stream``: a
        stream of lines, which may go to a character device. None, an empty path and ``-`` (stdout) are not
        judged.
        """
        if path is None or str(path) in ("", "-"):
            return
        shown = os.fsdecode(path)
        if stream and is_open_descriptor(shown):
            return  # /dev/stderr, /dev/fd/3: a stream the caller's shell opened already, not a file to judge
        real = _real(path)

        def refuse(why: str) -> OutputError:
            return OutputError(shown, f"refused as {option}: {why}; nothing was written")

        other = self._outputs.get(real, option)
        if other != option:
            raise refuse(f"it is also where {other} goes; give each output a path of its own")
        if inside is not None and not _inside(real, _real(inside)):
            raise refuse(f"through a link it leaves the folder {os.fsdecode(inside)} it belongs to (it is {real})")
        info = _stat(real)
        if info is not None:
            same = self._inodes.get((info.st_dev, info.st_ino))
            if same is not None:
                how = "" if Path(os.path.abspath(path)) == same.real else f" (the same file as {same.shown})"
                raise refuse(f"it is {same.what} of this run{how}")
        for entry in self._inputs:
            if entry.folder and _inside(real, entry.real):
                raise refuse(f"it lies inside {entry.what} {entry.shown}, which this run reads")
        if folder:
            self._check_folder(real, info, names, refuse)
        else:
            self._check_file(info, stream, refuse)
        parent = _stat(real.parent)
        if parent is not None and stat.S_ISDIR(parent.st_mode) and read_only_by_mode(parent):
            raise refuse(f"its folder {real.parent} is read-only")
        self._outputs[real] = option

    def _check_file(self, info: os.stat_result | None, stream: bool, refuse: _Refusal) -> None:
        if info is None:
            return
        mode = info.st_mode
        if stat.S_ISREG(mode):
            if read_only_by_mode(info):
                raise refuse("the file is read-only")
            return
        if stat.S_ISCHR(mode) and stream:
            return
        raise refuse(f"it is {describe_mode(mode)}, not a regular file")

    def _check_folder(self, real: Path, info: os.stat_result | None, names: str | None, refuse: _Refusal) -> None:
        if info is None:
            return
        if not stat.S_ISDIR(info.st_mode):
            raise refuse(f"it is {describe_mode(info.st_mode) if not stat.S_ISREG(info.st_mode) else 'a file'}, "
                         "not a folder")
        if read_only_by_mode(info):
            raise refuse("the folder is read-only")
        for entry in list(self._inodes.values()) if names is not None else ():
            if entry.real.parent == real and fnmatch.fnmatch(entry.real.name, names):
                raise refuse(f"it holds {entry.what} {entry.shown}, which this run reads and would write over")


def is_open_descriptor(path: str) -> bool:
    """Whether ``path`` names a descriptor the process holds already (``/dev/stderr``, ``/dev/fd/3``): a stream
    the caller's shell opened, with its reader if it is a pipe, not a file to judge."""
    return path.startswith(_DESCRIPTORS)


def _stat(path: Path) -> os.stat_result | None:
    try:
        return os.stat(path)
    except (OSError, ValueError):
        return None
