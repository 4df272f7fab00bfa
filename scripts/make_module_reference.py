"""Write docs/modules.md, the reference of objrec's built-in modules, from their declarations.

    .venv/bin/python scripts/make_module_reference.py           # write docs/modules.md
    .venv/bin/python scripts/make_module_reference.py --check   # exit 1 when docs/modules.md is out of date

Every parameter is declared once (type, default, bounds, description, when it matters) and every rule between
parameters too, so the reference is generated from the registered module types rather than written by hand:
a changed default or bound changes the page, and tests/docs/test_module_reference.py fails until it is
regenerated. Only the built-in modules are listed (the classes of objrec's own packages), so a plug-in
installed in the environment does not change the page.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path
from typing import Any

from objrec_core import registry

ROOT = Path(__file__).resolve().parents[1]
OUTPUT = ROOT / "docs" / "modules.md"
#: The packages whose module types are built in.
BUILT_IN = ("objrec_core", "objrec2d", "objrec3d")
COMMAND = "python scripts/make_module_reference.py"

_HEADER = f"""# Module reference

Every built-in filter and detector with its parameters, generated from their declarations by
`{COMMAND}`: do not edit it by hand (a test fails when this page is out of date).
A parameter file names a module by its type and sets any of these parameters ([the format](parameter-files.md));
the definition GUI builds its panels from the same declarations. "Allowed" is what validation accepts; "slider" is the
GUI's range where it is narrower (a typed value may go beyond it, up to the allowed bounds).
"""


def _cell(text: Any) -> str:
    """Text for a Markdown table cell: one line, pipes escaped, RST literals as Markdown code."""
    return " ".join(str(text).replace("``", "`").split()).replace("|", "\\|")


def _code(value: Any) -> str:
    return f"`{value!r}`" if value is not None else "none"


def _summary(cls: type) -> str:
    """The first paragraph of the class docstring."""
    doc = inspect.getdoc(cls) or ""
    return _cell(doc.split("\n\n")[0]) if doc else "(no description)"


def _slider(spec: Any) -> str:
    soft = (getattr(spec, "soft_min", None), getattr(spec, "soft_max", None))
    hard = (getattr(spec, "min", None), getattr(spec, "max", None))
    if soft == hard or None in soft:
        return ""
    return f"; slider {soft[0]:g}..{soft[1]:g}"


def module_section(name: str, cls: Any) -> list[str]:
    """One module's section: kind, summary, a table of its parameters, its rules."""
    lines = [f"## {name}", "", f"Kind `{cls.kind}` · `{cls.__module__}.{cls.__qualname__}`", "", _summary(cls), ""]
    specs = cls.parameter_specs()
    if specs:
        lines += ["| parameter | type | default | allowed | description | relevant |", "|---|---|---|---|---|---|"]
        for spec in specs:
            kind = spec.type_name + (", optional" if spec.optional else "")
            relevant = spec.relevance_text() or "always"
            lines.append(f"| `{spec.name}` | {kind} | {_code(spec.default)} | {_cell(spec.describe() + _slider(spec))}"
                         f" | {_cell(spec.doc)} | {_cell(relevant)} |")
    else:
        lines.append("No parameters.")
    rules = cls.parameter_rules()
    if rules:
        lines += ["", "Rules: " + "; ".join(_cell(rule.describe()) for rule in rules) + "."]
    return [*lines, ""]


def built_in_modules() -> dict[str, Any]:
    """The registered module types of objrec's own packages, by kind, then name."""
    types = registry.module_types()
    own = {name: cls for name, cls in types.items() if cls.__module__.split(".")[0] in BUILT_IN}
    return dict(sorted(own.items(), key=lambda item: (item[1].kind or "", item[0])))


def render() -> str:
    """The whole page, as the declarations say it today."""
    modules = built_in_modules()
    lines = [_HEADER]
    for kind in sorted({cls.kind or "" for cls in modules.values()}):
        names = [name for name, cls in modules.items() if (cls.kind or "") == kind]
        lines.append(f"- kind `{kind}`: " + ", ".join(f"[{name}](#{name.lower()})" for name in names))
    lines.append("")
    for name, cls in modules.items():
        lines += module_section(name, cls)
    return "\n".join(lines).rstrip("\n") + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when docs/modules.md is out of date")
    args = parser.parse_args(argv)
    text = render()
    if args.check:
        current = OUTPUT.read_text(encoding="utf-8") if OUTPUT.exists() else ""
        if current != text:
            print(f"{OUTPUT.relative_to(ROOT)} is out of date: run {COMMAND}", file=sys.stderr)
            return 1
        return 0
    OUTPUT.write_text(text, encoding="utf-8")
    print(f"wrote {OUTPUT.relative_to(ROOT)} ({len(built_in_modules())} modules)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
