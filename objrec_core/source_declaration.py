"""A source type's forms declared apart from its implementation, so the registry knows them without importing it.

Choosing a source needs only what a spec can look like: the kind, the schemes (``bag:``), the file extensions
(``.bag``, ``.mcap``) and which folders it reads. A :class:`~objrec_core.sources.FrameSource` subclass
declares these itself, which is enough when importing it is cheap. A source whose module imports something
heavy or optional (the bag sources import ``objrec_ros`` and rosbags) is installed instead as a
:class:`DeclaredSource`, defined in a module free of heavy imports, naming its implementation; the
registry reads the declaration to parse specs, list accepted forms and pick the source, and imports the
implementation only when a spec chose it. Loading checks the implementation declares the same forms, so the
two cannot drift apart unnoticed.
"""

from __future__ import annotations

import importlib
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .sources import FrameSource

_lock = threading.RLock()  # an implementation importing another declared source must not deadlock


@dataclass(frozen=True)
class DeclaredSource:
    """What a spec naming this source looks like, and where its FrameSource subclass lives.

    ``implementation`` is ``package.module:Class``. ``folder_marker`` is a file name marking a folder as
    this source's own (``metadata.yaml``: a ROS 2 bag folder), which scores 2 and beats a plain folder
    reader; ``folders`` reads any folder as a fallback (score 1), as :meth:`FrameSource.path_score` does.
    """

    kind: str
    implementation: str
    schemes: tuple[str, ...] = ()
    extensions: tuple[str, ...] = ()
    folders: bool = False
    folder_marker: str = ""
    summary: str = ""
    _loaded: list[type[FrameSource]] = field(default_factory=list, compare=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "schemes", tuple(s.lower() for s in self.schemes))
        object.__setattr__(self, "extensions", tuple(e.lower() for e in self.extensions))

    @property
    def registry_origin(self) -> str:
        """The implementation stands for this declaration in the registry's clash messages."""
        return self.implementation

    def path_score(self, path: Path) -> int:
        """As :meth:`FrameSource.path_score`: 2 by extension or marker file, 1 for a folder fallback."""
        if path.is_dir():
            if self.folder_marker and (path / self.folder_marker).is_file():
                return 2
            return 1 if self.folders else 0
        return 2 if path.suffix.lower() in self.extensions else 0

    def load(self) -> type[FrameSource]:
        """Import the implementation (once) and check that it declares what this declaration says.

        Raises ImportError or TypeError saying what is wrong; the registry words it as a plug-in error.
        """
        with _lock:
            if self._loaded:
                return self._loaded[0]
            module_name, _, attr = self.implementation.partition(":")
            klass: Any = importlib.import_module(module_name.strip())
            for part in attr.strip().split("."):
                klass = getattr(klass, part)
            if not (isinstance(klass, type) and issubclass(klass, FrameSource)):
                raise TypeError(f"{self.implementation} is not a FrameSource subclass")
            declared = (self.kind, set(self.schemes), set(self.extensions), self.folders)
            actual = (klass.kind, set(klass.schemes), set(klass.extensions), klass.folders)
            if declared != actual:
                raise TypeError(f"{self.implementation} declares kind, schemes, extensions, folders {actual}, "
                                f"its declaration {declared}")
            self._loaded.append(klass)
            return klass
