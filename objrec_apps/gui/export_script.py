"""File > Export as Python script: the pipeline on screen as a standalone program written with the objrec API.

The script constructs every module in code, with its id, its own object name and all of its values spelled
out, so a user can read and change it like any program they wrote themselves (GRIP users ask for exactly
this); a module's state (a feature detector's target) is not something one writes by hand, so it is embedded
as data and handed to the module's own ``prepare_state``/``apply_state``. The script runs the system on a
source and prints one JSON line per frame, the same lines ``objrec-detect`` prints for the parameter file.

This module names no kind package: the import of each module class comes from the class itself.
"""

from __future__ import annotations

import base64
import builtins
import importlib
import keyword
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from PySide6.QtWidgets import QFileDialog, QWidget

from objrec_core import RecognitionSystem, UnknownModuleError, get_kind
from objrec_core.modules import Detector
from strictio import OutputError, write_atomically

#: Width of the base64 lines of embedded bytes (a target picture): readable diffs, no overlong lines.
B64_LINE = 76


def _import_path(cls: type) -> str:
    """The shortest public module a class can be imported from (``objrec2d`` rather than
    ``objrec2d.hsv_filter``), so the script reads like code a user would write."""
    top = cls.__module__.split(".")[0]
    try:
        if getattr(importlib.import_module(top), cls.__name__, None) is cls:
            return top
    except ImportError:  # pragma: no cover - the class was imported, so its package imports
        pass
    return cls.__module__


def _literal(value: Any, indent: int = 0) -> str:
    """Python source for YAML-safe data; bytes become a base64 literal decoded at run time (the source stays
    ASCII and of sane line length)."""
    pad = " " * (indent + 4)
    if isinstance(value, bytes):
        text = base64.b64encode(value).decode("ascii")
        chunks = [text[i:i + B64_LINE] for i in range(0, len(text), B64_LINE)] or [""]
        body = "\n".join(f'{pad}"{chunk}"' for chunk in chunks)
        return f"base64.b64decode(\n{body}\n{' ' * indent})"
    if isinstance(value, Mapping):
        if not value:
            return "{}"
        items = ",\n".join(f"{pad}{key!r}: {_literal(item, indent + 4)}" for key, item in value.items())
        return "{\n" + items + ",\n" + " " * indent + "}"
    if isinstance(value, list | tuple):
        if not value:
            return "[]"
        items = ",\n".join(f"{pad}{_literal(item, indent + 4)}" for item in value)
        return "[\n" + items + ",\n" + " " * indent + "]"
    if value is None or isinstance(value, bool | int | float | str):
        return repr(value)
    raise TypeError(f"cannot write {type(value).__name__} into a script")


def _variable(module_id: str, taken: set[str]) -> str:
    """A lower-case Python name for a module id (ids may hold characters a name cannot, or be a class's name)."""
    name = "".join(c if c.isalnum() or c == "_" else "_" for c in module_id).lower() or "module"
    if name[0].isdigit() or keyword.iskeyword(name) or hasattr(builtins, name):  # ``open`` would hide open()
        name = f"m_{name}"
    base, n = name, 2
    while name in taken:
        name, n = f"{base}_{n}", n + 1
    taken.add(name)
    return name


def script_text(system: RecognitionSystem, *, source: str = "demo", origin: str = "") -> str:
    """The standalone script for ``system``: builds it module by module, opens ``source`` (or the first
    argument) and prints each frame's detections as JSON Lines."""
    imports: dict[str, set[str]] = {}
    lines: list[str] = []
    names: list[str] = []
    taken = {"base64", "sys", "argparse", "system", "director", "source", "main", "args", "parser", "state"}
    needs_base64 = False
    with system.lock:
        modules = list(system.modules)
        taken |= {type(module).__name__ for module in modules}
        kind = system.kind
        object_name, description = system.object_name, system.description
        for module in modules:
            cls = type(module)
            imports.setdefault(_import_path(cls), set()).add(cls.__name__)
            var = _variable(module.id, taken)
            names.append(var)
            arguments = [repr(module.id)]
            if isinstance(module, Detector) and module.own_object_name is not None:
                arguments.append(f"object_name={module.own_object_name!r}")
            arguments += [f"{name}={value!r}" for name, value in module.get_parameters().items()]
            lines.append(f"    {var} = {cls.__name__}(\n        " + ",\n        ".join(arguments) + ",\n    )")
            state = module.get_state() if module.keeps_state() else None
            if state is not None:
                literal = _literal(state, 4)
                needs_base64 = needs_base64 or "base64.b64decode(" in literal
                lines.append(f"    state = {literal}")
                lines.append(f"    {var}.apply_state({var}.prepare_state(state, {var}.get_parameters()))")
    header = [
        "#!/usr/bin/env python3",
        f'"""{(object_name or "object")}: a recognition pipeline written out by objrec-define'
        + (f" from {origin}" if origin else "") + ".",
        "",
        "Run it on a source (default: " + source + ") and it prints one JSON line per frame with the objects found,",
        "as objrec-detect does for the parameter file:",
        "",
        "    python SCRIPT.py [SOURCE] [--max-frames N]",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        "import argparse",
    ]
    if needs_base64:
        header.append("import base64")
    header += ["import sys", ""]
    header += [f"from {path} import {', '.join(sorted(classes))}" for path, classes in sorted(imports.items())]
    header.append("from objrec_core import DetectionDirector, JSONLinesSink, RecognitionSystem, open_source")
    body = [
        "",
        "",
        "def build_system() -> RecognitionSystem:",
        '    """The pipeline, module by module, with every value it was exported with."""',
        *lines,
        "    return RecognitionSystem(",
        f"        [{', '.join(names)}],",
        f"        object_name={object_name!r},",
        f"        description={description!r},",
        "    )",
        "",
        "",
        "def main(argv: list[str] | None = None) -> int:",
        "    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])",
        f"    parser.add_argument('source', nargs='?', default={source!r}, help='a source spec or path')",
        "    parser.add_argument('--max-frames', type=int, default=None)",
        "    args = parser.parse_args(argv)",
        "    system = build_system()",
        f"    source = open_source(args.source, {kind!r})",
        "    director = DetectionDirector(system, sinks=[JSONLinesSink(sys.stdout)])",
        "    try:",
        "        director.run_all(source, args.max_frames)",
        "    finally:",
        "        source.close()",
        "    return 0",
        "",
        "",
        'if __name__ == "__main__":',
        "    raise SystemExit(main())",
        "",
    ]
    return "\n".join(header + body)


def export_script(system: RecognitionSystem, path: str | Path, *, source: str = "demo", origin: str = "") -> Path:
    """Write the script for ``system`` to ``path`` (atomically: a failed export leaves no half script)."""
    path = Path(path)
    write_atomically(path, script_text(system, source=source, origin=origin))
    return path


def export_dialog(
    window: QWidget, system: RecognitionSystem, files: Any, report: Callable[..., None], path: str | Path | None = None
) -> bool:
    """File > Export as Python script: ask where (beside the parameter file, named after it), write, report.
    Without a detector there is nothing the script could print, so it says so instead of writing one."""
    if not system.detectors:
        report("nothing to export: the pipeline has no detector", error=True)
        return False
    if path is None:
        base = files.path.with_suffix(".py") if files.path else Path(files.last_folder()) / (
            Path(files.origin or "objrec_pipeline.yaml").stem + ".py")
        chosen, _ = QFileDialog.getSaveFileName(window, "Export as Python script", str(base), "Python (*.py)")
        if not chosen:
            return False
        path = chosen
    origin = files.path.name if files.path else (files.origin or "")
    try:
        kind = get_kind(system.kind) if system.kind else None
        written = export_script(system, path, source=kind.demo_spec if kind else "demo", origin=origin)
    except (OSError, OutputError, TypeError, UnknownModuleError) as exc:
        report(f"export to {path} failed: {exc}", error=True)
        return False
    report(f"exported the pipeline as {written}: run it with python {written.name} [SOURCE]")
    return True
