"""The parameter-file schema: a YAML document checked against the registry and the modules' declarations.

Validation builds (or reuses) every module and checks every value, rule and state before anything is
applied, so a file loads whole or not at all. The document's own fields are a table (:func:`file_fields`);
each module's parameters are checked by its declarations. Errors are the one error of every file reader:
``params.yaml:12: pipeline[1].parameters.h_max: 300 is invalid: out of range, allowed int in 0..179``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from declare import Int, Str
from declare.fields import Document, DocumentError, Free, ListOf, Place, Record, Value, not_blank
from declare.fields import read_document as read_yaml_document
from declare.parameters import ParameterError
from strictio import YAMLLimits

from .modules import Detector
from .parametrizable import Parametrizable, check_module_id
from .registry import UnknownModuleError, kind_names, module_type

FORMAT_VERSION = 1
TOP_KEYS = ("format_version", "object_name", "kind", "description", "pipeline")
ENTRY_KEYS = ("type", "id", "object_name", "parameters", "state")
#: A parameter file with an embedded target is about 200 KB; 32 MiB leaves room for large targets.
PARAMETER_FILE_LIMITS = YAMLLimits(max_bytes=32 * 1024 * 1024, max_depth=32)


#: What is wrong with a parameter file: the one error of every file reader (``FILE:LINE: key.path: ...``),
#: one line whatever the file holds (control characters in names and values are shown escaped).
ParameterFileError = DocumentError


def _format_version(value: int) -> str | None:
    return None if value <= FORMAT_VERSION else f"newer than this objrec reads ({FORMAT_VERSION})"


def _known_kind(value: str) -> str | None:
    known = kind_names()
    return None if value in known else f"expected one of {', '.join(known)}"


_ENTRY_FIELDS = Record({
    "type": Value(Str("", "the module's registered type"), required=True),
    "id": Value(Str("", "the module's id, unique in the file"), default=None),
    "object_name": Value(Str("", "the name of what a detector finds"), default=None),
    "parameters": Free(kinds=(dict, type(None)), what="a mapping of parameter names to values"),
    "state": Free(doc="a module's non-scalar state (a feature target)"),
})


def file_fields() -> Record:
    """The table of a parameter file's own fields (the kinds it may name are those registered now)."""
    return Record({
        "format_version": Value(Int(FORMAT_VERSION, "the file format", min=1), required=True, check=_format_version),
        "object_name": Value(Str("object", "what the system recognises"), check=not_blank),
        "kind": Value(Str("", "the data kind"), required=True, check=_known_kind),
        "description": Str("", "what the system is for"),
        "pipeline": ListOf(_ENTRY_FIELDS, required=True, min_items=1, doc="the modules, in order"),
    })


@dataclass
class Entry:
    """A validated pipeline entry, ready to apply."""

    type_name: str
    module_id: str
    object_name: str | None
    values: dict[str, Any]
    prepared_state: Any
    module: Parametrizable


@dataclass
class ParameterDocument:
    """A validated file: its identity, kind and entries (modules built or reused, nothing applied yet)."""

    path: Path
    kind: str
    object_name: str
    description: str
    entries: list[Entry]

    def same_pipeline(self, modules: tuple[Parametrizable, ...]) -> bool:
        """Whether the file holds exactly these modules (so loading keeps them, and their panels)."""
        return len(self.entries) == len(modules) and all(e.module is m for e, m in zip(self.entries, modules,
                                                                                       strict=True))


def _read(path: Path) -> Document:
    """The file as a document (its data a mapping), through the project's strict reader."""
    document = read_yaml_document(path, PARAMETER_FILE_LIMITS)
    if not isinstance(document.data, dict):
        raise document.root.fail(f"expected a mapping at the top, found {type(document.data).__name__}")
    return document


def read_document(path: Path) -> dict[str, Any]:
    """The file's YAML mapping, through the project's strict reader."""
    return _read(path).data


def peek_kind(path: str | os.PathLike[str]) -> str:
    """The ``kind`` a parameter file declares, without building its modules."""
    document = _read(Path(path))
    kind = document.data.get("kind")
    if not isinstance(kind, str):
        where = document.root.key("kind")
        raise where.fail("missing") if kind is None else where.fail("expected text", kind)
    return kind


def validate_document(path: Path, existing: tuple[Parametrizable, ...] | None = None) -> ParameterDocument:
    """Read and check a whole file. Modules of ``existing`` whose position, type and id match are reused
    (validated against, not changed); every other entry gets a new module."""
    document = _read(path)
    doc = file_fields().read(document.data, document.root)
    at = document.root.key("pipeline")
    entries: list[Entry] = []
    ids: set[str] = set()
    for index, raw in enumerate(doc["pipeline"]):
        entry = _validate_entry(at.item(index), index, raw, doc["kind"], existing)
        if entry.module_id in ids:
            raise at.item(index).key("id").fail("used twice", entry.module_id)
        ids.add(entry.module_id)
        entries.append(entry)
    return ParameterDocument(path, doc["kind"], doc["object_name"], doc["description"], entries)


def _validate_entry(at: Place, index: int, raw: dict[str, Any], kind: str,
                    existing: tuple[Parametrizable, ...] | None) -> Entry:
    type_name = raw["type"]
    try:
        klass = module_type(type_name)
    except UnknownModuleError as exc:
        raise at.key("type").fail(str(exc)) from None
    if klass.kind is not None and klass.kind != kind:
        raise at.key("type").fail(f"{type_name} works on {klass.kind} data, the file is {kind}")
    module_id = raw["id"] if raw["id"] is not None else type_name
    try:
        check_module_id(module_id)
    except ValueError as exc:
        raise at.key("id").fail(str(exc)) from None
    object_name = raw["object_name"]
    if object_name is not None and not issubclass(klass, Detector):
        raise at.key("object_name").fail("only detectors name the objects they find")
    parameters = raw["parameters"] or {}
    module = existing[index] if existing and index < len(existing) else None
    if module is None or type(module) is not klass or module.id != module_id:
        try:
            module = klass(module_id)  # new, or a stand-in that shows the mismatch after validation
        except ParameterError as exc:  # a default this installation cannot serve
            raise at.key("parameters").key(exc.parameter).fail(exc.rule) from None
    values = {}
    for name, value in parameters.items():
        try:
            values.update(module.validate_parameters({name: value}))
        except ParameterError as exc:
            raise at.key("parameters").key(name).fail(exc.rule, value) from None
    complete = {**klass.default_values(), **values}
    try:
        module.check_values(complete)
    except ParameterError as exc:
        raise at.key("parameters").key(exc.parameter).fail(exc.rule, exc.value) from None
    try:
        prepared = module.prepare_state(raw["state"], complete)
    except (ValueError, TypeError, KeyError) as exc:
        raise at.key("state").fail(str(exc)) from None
    return Entry(type_name, module_id, object_name, values, prepared, module)
