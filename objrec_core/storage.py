"""ParameterStorage: one YAML parameter file per recognition system, pipeline included.

The file names each module's registered type and its id, so two modules of one class coexist (the seed's
``ClassName/param`` lines could not). Loading validates the whole file against the modules' declarations
before anything changes; saving goes through a temporary file and ``os.replace``, so a crash mid-save
leaves the old file whole.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from .modules import Detector
from .parameters import ParameterError, short_repr
from .parametrizable import Parametrizable, check_module_id
from .registry import UnknownModuleError, module_type
from .system import PipelineError, RecognitionSystem

FORMAT_VERSION = 1
KINDS = ("2d", "3d")
_TOP_KEYS = {"format_version", "object_name", "kind", "description", "pipeline"}
_ENTRY_KEYS = {"type", "id", "object_name", "parameters", "state"}


class ParameterFileError(Exception):
    """What is wrong with a parameter file: the file, the key path and the problem."""

    def __init__(self, path: str | os.PathLike[str], key_path: str, message: str) -> None:
        self.path = str(path)
        self.key_path = key_path
        self.message = message
        where = f"{self.path}: {key_path}" if key_path else self.path
        super().__init__(f"{where}: {message}")


@dataclass
class _Entry:
    """A validated pipeline entry, ready to apply."""

    type_name: str
    module_id: str
    object_name: str | None
    values: dict[str, Any]
    prepared_state: Any
    module: Parametrizable


class _StrictLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that also refuses what a parameter file never needs and could hide a mistake or
    an attack: duplicate keys (the first would be silently dropped) and aliases (an alias bomb expands a
    small file into gigabytes)."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.composer.ComposerError(
                None, None, "aliases (*name) are not allowed in parameter files", event.start_mark
            )
        return super().compose_node(parent, index)

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, list | dict):
                continue  # unhashable: the base class reports it
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {short_repr(key)} appears twice", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep)


def _read_document(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ParameterFileError(path, "", "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterFileError(path, "", f"cannot be read: {exc}") from None
    try:
        doc = yaml.load(text, Loader=_StrictLoader)  # yaml.safe_load with the stricter SafeLoader above
    except RecursionError:
        raise ParameterFileError(path, "", "not valid YAML: nested too deeply") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = exc.problem or str(exc)
        if "could not determine a constructor" in str(exc):
            problem = f"{problem} (tags that build Python objects are not allowed in parameter files)"
        raise ParameterFileError(path, where, f"not valid YAML: {problem}") from None
    except yaml.YAMLError as exc:
        raise ParameterFileError(path, "", f"not valid YAML: {exc}") from None
    if not isinstance(doc, dict):
        raise ParameterFileError(path, "", f"expected a mapping at the top, found {type(doc).__name__}")
    return doc


def _require(path: Path, key: str, value: Any, kind: type | tuple[type, ...], what: str) -> Any:
    if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
        raise ParameterFileError(path, key, f"expected {what}, found {short_repr(value)}")
    return value


class ParameterStorage:
    """Saves and loads the parameters and state of a recognition system's modules.

    ``add_parametrizable`` builds the system in code, as the seed's apps did; ``build_system`` builds one
    from a file through the module registry, so the headless app can run any parameter file.
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
        doc: dict[str, Any] = {
            "format_version": FORMAT_VERSION,
            "object_name": system.object_name,
            "kind": system.kind,
        }
        if system.description:
            doc["description"] = system.description
        doc["pipeline"] = pipeline
        return doc

    def save_parameters(self, path: str | os.PathLike[str]) -> None:
        """Write the file atomically: a temporary file in the same folder, then ``os.replace``."""
        path = Path(path)
        if not self.system.modules:
            raise ParameterFileError(path, "pipeline", "the pipeline is empty; add a module before saving")
        if self.system.kind is None:
            raise ParameterFileError(path, "kind", "no module declares its data kind (2d or 3d)")
        doc = self.to_document()
        try:
            text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=100)
        except yaml.representer.RepresenterError as exc:
            raise ParameterFileError(path, "", f"a value cannot be written as YAML: {exc}") from None
        write_atomically(path, text)

    # -- loading -----------------------------------------------------------------------------------------
    def load_parameters(self, path: str | os.PathLike[str]) -> None:
        """Load a file into this system's modules. The file's pipeline must match them (ids and types);
        to replace the pipeline itself use ``load_system``. Nothing changes unless the whole file is valid.
        """
        path = Path(path)
        existing = self.system.modules
        doc, entries = self._validate(path, existing)
        if len(entries) != len(existing) or any(e.module is not m for e, m in zip(entries, existing, strict=False)):
            current = [f"{m.type_name} {m.id}" for m in existing]
            in_file = [f"{e.type_name} {e.module_id}" for e in entries]
            raise ParameterFileError(
                path, "pipeline", f"holds {in_file}, this system has {current}; open it as a new system instead"
            )
        self._apply(doc, entries, replace=False)

    def load_system(self, path: str | os.PathLike[str]) -> None:
        """Replace this system's whole pipeline with the file's, all or nothing."""
        path = Path(path)
        doc, entries = self._validate(path, None)
        try:
            RecognitionSystem.check_modules([e.module for e in entries], doc["kind"])
        except PipelineError as exc:
            raise ParameterFileError(path, "pipeline", str(exc)) from None
        self._apply(doc, entries, replace=True)

    def _apply(self, doc: dict[str, Any], entries: list[_Entry], replace: bool) -> None:
        """Apply a validated file as one change: observers hear of it only when every module has it."""
        system = self.system
        with system.lock:
            for entry in entries:
                module = entry.module
                module.load(entry.values, entry.prepared_state, notify=False)
                if isinstance(module, Detector):
                    module.own_object_name = entry.object_name
            system.set_identity(doc.get("object_name", "object"), doc.get("description", ""), notify=False)
            if replace:
                system.set_modules([e.module for e in entries], kind=doc["kind"], notify=False)
        for entry in entries:
            entry.module.notify()
        system.notify()

    def _validate(self, path: Path, existing: tuple[Parametrizable, ...] | None) -> tuple[dict[str, Any], list[_Entry]]:
        doc = _read_document(path)
        unknown = sorted(set(map(str, doc)) - _TOP_KEYS)
        if unknown:
            raise ParameterFileError(path, unknown[0], f"unknown key (allowed: {', '.join(sorted(_TOP_KEYS))})")
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
        if kind not in KINDS:
            raise ParameterFileError(path, "kind", f"expected one of {', '.join(KINDS)}, found {short_repr(kind)}")
        _require(path, "object_name", doc.get("object_name", "object"), str, "text")
        _require(path, "description", doc.get("description", ""), str, "text")
        pipeline = _require(path, "pipeline", doc["pipeline"], list, "a list of modules")
        if not pipeline:
            raise ParameterFileError(path, "pipeline", "is empty; a system needs at least one module")
        entries: list[_Entry] = []
        ids: set[str] = set()
        for index, raw in enumerate(pipeline):
            entry = self._validate_entry(path, index, raw, kind, existing)
            if entry.module_id in ids:
                raise ParameterFileError(path, f"pipeline[{index}].id", f"{entry.module_id!r} is used twice")
            ids.add(entry.module_id)
            entries.append(entry)
        return doc, entries

    def _validate_entry(
        self, path: Path, index: int, raw: Any, kind: str, existing: tuple[Parametrizable, ...] | None
    ) -> _Entry:
        at = f"pipeline[{index}]"
        if not isinstance(raw, dict):
            raise ParameterFileError(
                path, at, f"expected a mapping with type, id and parameters, found {short_repr(raw)}"
            )
        unknown = sorted(set(map(str, raw)) - _ENTRY_KEYS)
        if unknown:
            raise ParameterFileError(
                path, f"{at}.{unknown[0]}", f"unknown key (allowed: {', '.join(sorted(_ENTRY_KEYS))})"
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
            module = klass(module_id)  # new, or a stand-in that shows the mismatch after validation
        probe = module
        values = {}
        for name, value in parameters.items():
            try:
                values.update(probe.validate_parameters({name: value}))
            except ParameterError as exc:
                raise ParameterFileError(
                    path, f"{at}.parameters.{name}", f"{short_repr(value)} is invalid: {exc.rule}"
                ) from None
        complete = {**{p.name: p.default for p in klass.parameter_specs()}, **values}
        try:
            probe.check_values(complete)
        except ParameterError as exc:
            raise ParameterFileError(
                path, f"{at}.parameters.{exc.parameter}", f"{short_repr(exc.value)} is invalid: {exc.rule}"
            ) from None
        try:
            prepared = probe.prepare_state(raw.get("state"), complete)
        except (ValueError, TypeError, KeyError) as exc:
            raise ParameterFileError(path, f"{at}.state", str(exc)) from None
        return _Entry(type_name, module_id, object_name, values, prepared, module)


def write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that a reader (or a crash) sees the old file or the new one, never half."""
    shown = path
    path = Path(os.path.realpath(path))  # a link keeps pointing at the file it shares
    folder = path.parent
    if not folder.is_dir():
        raise ParameterFileError(shown, "", f"cannot save: folder {shown.parent} does not exist")
    tmp_name = ""
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
        with os.fdopen(fd, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        with contextlib.suppress(FileNotFoundError):
            os.chmod(tmp_name, path.stat().st_mode & 0o777)
        if not path.exists():
            os.chmod(tmp_name, 0o644)
        os.replace(tmp_name, path)
    except OSError as exc:
        if tmp_name:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)
        raise ParameterFileError(shown, "", f"cannot save: {exc.strerror or exc}") from None
    except BaseException:
        if tmp_name:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)
        raise


def build_system(path: str | os.PathLike[str]) -> RecognitionSystem:
    """Build a whole recognition system from a parameter file, through the module registry."""
    system = RecognitionSystem()
    ParameterStorage(system).load_system(path)
    return system


def load_mapping(path: str | os.PathLike[str]) -> Mapping[str, Any]:
    """The raw validated-YAML document (for tools that only want to peek, e.g. at ``kind``)."""
    return _read_document(Path(path))
