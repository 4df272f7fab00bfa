"""The parameter-file schema: a YAML document checked against the registry and the modules' declarations.

Validation builds (or reuses) every module and checks every value, rule and state before anything is
applied, so a file loads whole or not at all. Errors name the file, the key path and the value.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from declare.parameters import ParameterError, printable, short_repr
from strictio import InputError, YAMLLimits, read_yaml
from strictio.errors import escape_controls

from .modules import Detector
from .parametrizable import Parametrizable, check_module_id
from .registry import UnknownModuleError, kind_names, module_type

FORMAT_VERSION = 1
TOP_KEYS = ("format_version", "object_name", "kind", "description", "pipeline")
ENTRY_KEYS = ("type", "id", "object_name", "parameters", "state")
#: A parameter file with an embedded target is about 200 KB; 32 MiB leaves room for large targets.
PARAMETER_FILE_LIMITS = YAMLLimits(max_bytes=32 * 1024 * 1024, max_depth=32)


class ParameterFileError(Exception):
    """What is wrong with a parameter file: the file, the key path and the problem.

    The text is one line whatever the file holds: control characters in names and values are shown escaped
    (``\\n``, ``\\x1b``), so a key cannot split the message or send a terminal its codes.
    """

    def __init__(self, path: str | os.PathLike[str], key_path: str, message: str) -> None:
        self.path = str(path)
        self.key_path = key_path
        self.message = message
        where = f"{self.path}: {key_path}" if key_path else self.path
        super().__init__(escape_controls(f"{where}: {message}"))


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


def read_document(path: Path) -> dict[str, Any]:
    """The file's YAML mapping, through the project's strict reader."""
    try:
        doc = read_yaml(path, PARAMETER_FILE_LIMITS)
    except InputError as exc:
        raise ParameterFileError(path, exc.where, exc.message) from None
    if not isinstance(doc, dict):
        raise ParameterFileError(path, "", f"expected a mapping at the top, found {type(doc).__name__}")
    return doc


def _require(path: Path, key: str, value: Any, kind: type | tuple[type, ...], what: str) -> Any:
    if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
        raise ParameterFileError(path, key, f"expected {what}, found {short_repr(value)}")
    return value


def validate_document(path: Path, existing: tuple[Parametrizable, ...] | None = None) -> ParameterDocument:
    """Read and check a whole file. Modules of ``existing`` whose position, type and id match are reused
    (validated against, not changed); every other entry gets a new module."""
    doc = read_document(path)
    unknown = sorted(str(k) for k in doc if k not in TOP_KEYS)
    if unknown:
        raise ParameterFileError(path, printable(unknown[0]), f"unknown key (allowed: {', '.join(TOP_KEYS)})")
    for key in ("format_version", "kind", "pipeline"):
        if key not in doc:
            raise ParameterFileError(path, key, "missing")
    version = _require(path, "format_version", doc["format_version"], int, "an integer")
    if version > FORMAT_VERSION:
        raise ParameterFileError(
            path, "format_version", f"{version} is newer than this objrec reads ({FORMAT_VERSION})"
        )
    if version < 1:
        raise ParameterFileError(path, "format_version", f"{version} is not a format version")
    kind = doc["kind"]
    known = kind_names()
    if not isinstance(kind, str) or kind not in known:
        raise ParameterFileError(path, "kind", f"expected one of {', '.join(known)}, found {short_repr(kind)}")
    object_name = _require(path, "object_name", doc.get("object_name", "object"), str, "text")
    if not object_name.strip():
        raise ParameterFileError(path, "object_name", "is empty")
    description = _require(path, "description", doc.get("description", ""), str, "text")
    pipeline = _require(path, "pipeline", doc["pipeline"], list, "a list of modules")
    if not pipeline:
        raise ParameterFileError(path, "pipeline", "is empty; a system needs at least one module")
    entries: list[Entry] = []
    ids: set[str] = set()
    for index, raw in enumerate(pipeline):
        entry = _validate_entry(path, index, raw, kind, existing)
        if entry.module_id in ids:
            raise ParameterFileError(path, f"pipeline[{index}].id", f"{entry.module_id!r} is used twice")
        ids.add(entry.module_id)
        entries.append(entry)
    return ParameterDocument(path, kind, object_name, description, entries)


def _validate_entry(path: Path, index: int, raw: Any, kind: str, existing: tuple[Parametrizable, ...] | None) -> Entry:
    at = f"pipeline[{index}]"
    if not isinstance(raw, dict):
        raise ParameterFileError(path, at, f"expected a mapping with type, id and parameters, found {short_repr(raw)}")
    unknown = sorted(str(k) for k in raw if k not in ENTRY_KEYS)
    if unknown:
        raise ParameterFileError(
            path, f"{at}.{printable(unknown[0])}", f"unknown key (allowed: {', '.join(ENTRY_KEYS)})"
        )
    if "type" not in raw:
        raise ParameterFileError(path, f"{at}.type", "missing")
    type_name = _require(path, f"{at}.type", raw["type"], str, "a module type name")
    try:
        klass = module_type(type_name)
    except UnknownModuleError as exc:
        raise ParameterFileError(path, f"{at}.type", str(exc)) from None
    if klass.kind is not None and klass.kind != kind:
        raise ParameterFileError(path, f"{at}.type", f"{type_name} works on {klass.kind} data, the file is {kind}")
    module_id = raw.get("id", type_name)
    try:
        check_module_id(module_id)
    except ValueError as exc:
        raise ParameterFileError(path, f"{at}.id", str(exc)) from None
    object_name = raw.get("object_name")
    if object_name is not None:
        if not issubclass(klass, Detector):
            raise ParameterFileError(path, f"{at}.object_name", "only detectors name the objects they find")
        _require(path, f"{at}.object_name", object_name, str, "text")
    parameters = raw.get("parameters")
    if parameters is None:
        parameters = {}
    if not isinstance(parameters, dict):
        raise ParameterFileError(path, f"{at}.parameters", f"expected a mapping, found {short_repr(parameters)}")
    module = existing[index] if existing and index < len(existing) else None
    if module is None or type(module) is not klass or module.id != module_id:
        try:
            module = klass(module_id)  # new, or a stand-in that shows the mismatch after validation
        except ParameterError as exc:  # a default this installation cannot serve
            raise ParameterFileError(path, f"{at}.parameters.{exc.parameter}", exc.rule) from None
    values = {}
    for name, value in parameters.items():
        try:
            values.update(module.validate_parameters({name: value}))
        except ParameterError as exc:
            raise ParameterFileError(
                path, f"{at}.parameters.{printable(name)}",
                f"{short_repr(value)} is invalid: {exc.rule}",
            ) from None
    complete = {**klass.default_values(), **values}
    try:
        module.check_values(complete)
    except ParameterError as exc:
        raise ParameterFileError(
            path, f"{at}.parameters.{exc.parameter}", f"{short_repr(exc.value)} is invalid: {exc.rule}"
        ) from None
    try:
        prepared = module.prepare_state(raw.get("state"), complete)
    except (ValueError, TypeError, KeyError) as exc:
        raise ParameterFileError(path, f"{at}.state", str(exc)) from None
    return Entry(type_name, module_id, object_name, values, prepared, module)
