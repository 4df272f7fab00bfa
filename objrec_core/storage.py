"""ParameterStorage: one YAML parameter file per recognition system, pipeline included.

The file names each module's registered type and its id, so two modules of one class coexist. Reading and
checking a file is ``schema.py``'s job; this module applies a checked file as one change and writes files
atomically (``strictio.write_atomically``), so a crash mid-save leaves the old file whole.
"""

from __future__ import annotations

import os
from enum import Enum
from pathlib import Path
from typing import Any

import yaml

from strictio import OutputError, write_atomically

from .modules import Detector
from .observer import Change
from .parametrizable import Parametrizable
from .schema import FORMAT_VERSION, ParameterDocument, ParameterFileError, peek_kind, validate_document
from .system import PipelineError, RecognitionSystem

__all__ = ["FORMAT_VERSION", "Opened", "ParameterSaveError", "ParameterStorage", "build_system", "peek_kind"]


class ParameterSaveError(ParameterFileError, OutputError):
    """A parameter file that cannot be saved (a full disk, a read-only file, a device at the path): both a
    ParameterFileError, as the GUI expects of its files, and a ``strictio.OutputError``, as every command
    maps to exit code 2. Whatever was at the path is untouched."""

    def __init__(self, path: str | os.PathLike[str], message: str) -> None:
        OutputError.__init__(self, path, message)
        self.key_path = self.where = self.rule = ""
        self.line = None

    def __reduce__(self) -> tuple[object, ...]:  # both a ValueError and an OSError: rebuilt by its own __init__
        return ParameterSaveError, (self.path, self.message)


class Opened(Enum):
    """What ``ParameterStorage.open`` did with the pipeline."""

    KEPT = "kept"  # the file holds the modules on screen: their values changed, the modules stayed
    REPLACED = "replaced"  # the file's pipeline replaced the system's


class ParameterStorage:
    """Saves and loads the parameters and state of a recognition system's modules.

    ``add_parametrizable`` builds the system in code; ``build_system`` builds one from a file through the
    module registry, so the headless app can run any parameter file.
    """

    def __init__(self, system: RecognitionSystem | None = None, object_name: str = "object") -> None:
        self.system = system if system is not None else RecognitionSystem(object_name=object_name)

    # -- the system's modules ----------------------------------------------------------------------------
    @property
    def parametrizables(self) -> tuple[Parametrizable, ...]:
        return self.system.modules

    def add_parametrizable(self, parametrizable: Parametrizable) -> None:
        self.system.add_module(parametrizable)

    # -- saving ------------------------------------------------------------------------------------------
    def to_document(self) -> dict[str, Any]:
        system = self.system
        pipeline = []
        for m in system.modules:
            entry: dict[str, Any] = {"type": m.type_name, "id": m.id}
            if isinstance(m, Detector) and m.own_object_name is not None:
                entry["object_name"] = m.own_object_name
            entry["parameters"] = m.get_parameters()
            state = m.get_state()
            if state is not None:
                entry["state"] = state
            pipeline.append(entry)
        doc: dict[str, Any] = {"format_version": FORMAT_VERSION, "object_name": system.object_name,
                               "kind": system.kind}
        if system.description:
            doc["description"] = system.description
        doc["pipeline"] = pipeline
        return doc

    def to_yaml(self) -> str:
        return yaml.safe_dump(self.to_document(), sort_keys=False, allow_unicode=True, width=100)

    def save_parameters(self, path: str | os.PathLike[str]) -> None:
        """Write the file atomically: a temporary file in the same folder, then ``os.replace``.

        A failure to write is a ParameterSaveError; a system that cannot be saved (an empty pipeline, a value
        YAML cannot hold) a ParameterFileError."""
        path = Path(path)
        if not self.system.modules:
            raise ParameterFileError(path, "pipeline", "the pipeline is empty; add a module before saving")
        if self.system.kind is None:
            raise ParameterFileError(path, "kind", "no module declares its data kind")
        try:
            text = self.to_yaml()
        except yaml.representer.RepresenterError as exc:
            raise ParameterFileError(path, "", f"a value cannot be written as YAML: {exc}") from None
        try:
            write_atomically(path, text)
        except OutputError as exc:
            raise ParameterSaveError(path, exc.message) from None

    # -- loading -----------------------------------------------------------------------------------------
    def open(self, path: str | os.PathLike[str]) -> Opened:
        """Load a file, keeping the modules when it holds the pipeline already there (same types and ids in
        the same order) and replacing the pipeline otherwise; nothing changes unless the whole file is valid."""
        document = validate_document(Path(path), self.system.modules)
        if document.same_pipeline(self.system.modules):
            self._apply(document, replace=False)
            return Opened.KEPT
        self._replace(document)
        return Opened.REPLACED

    def load_parameters(self, path: str | os.PathLike[str]) -> None:
        """Load a file into this system's modules. The file's pipeline must match them (ids and types);
        to replace the pipeline itself use ``load_system``. Nothing changes unless the whole file is valid.
        """
        path = Path(path)
        existing = self.system.modules
        document = validate_document(path, existing)
        if not document.same_pipeline(existing):
            current = [f"{m.type_name} {m.id}" for m in existing]
            in_file = [f"{e.type_name} {e.module_id}" for e in document.entries]
            raise ParameterFileError(
                path, "pipeline", f"holds {in_file}, this system has {current}; open it as a new system instead"
            )
        self._apply(document, replace=False)

    def load_system(self, path: str | os.PathLike[str]) -> None:
        """Replace this system's whole pipeline with the file's, all or nothing."""
        self._replace(validate_document(Path(path), None))

    def _replace(self, document: ParameterDocument) -> None:
        try:
            RecognitionSystem.check_modules([e.module for e in document.entries], document.kind)
        except PipelineError as exc:
            raise ParameterFileError(document.path, "pipeline", str(exc)) from None
        self._apply(document, replace=True)

    def _apply(self, document: ParameterDocument, replace: bool) -> None:
        """Apply a validated file as one change: observers hear of it only when every module has it."""
        system = self.system
        heard: list[tuple[Parametrizable, list[Change]]] = []
        with system.lock:
            for entry in document.entries:
                module = entry.module
                changes = module.load(entry.values, entry.prepared_state, notify=False)
                if isinstance(module, Detector) and module.own_object_name != entry.object_name:
                    changes.append(Change(module, "object_name", module.own_object_name, entry.object_name))
                    module.own_object_name = entry.object_name
                heard.append((module, changes))
            old = (system.object_name, system.description, system.modules)
            system.set_identity(document.object_name, document.description, notify=False)
            if replace:
                system.set_modules([e.module for e in document.entries], kind=document.kind, notify=False)
        for module, changes in heard:
            if changes:
                module.notify(changes)
        system_changes = [
            Change(system, name, before, after)
            for name, before, after in zip(("object_name", "description", "pipeline"), old,
                                           (system.object_name, system.description, system.modules), strict=True)
            if before != after
        ]
        system.notify(system_changes or [Change(system, "file", None, str(document.path))])


def build_system(path: str | os.PathLike[str]) -> RecognitionSystem:
    """Build a whole recognition system from a parameter file, through the module registry."""
    system = RecognitionSystem()
    ParameterStorage(system).load_system(path)
    return system
