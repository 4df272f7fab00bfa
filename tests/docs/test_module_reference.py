"""docs/modules.md is what scripts/make_module_reference.py makes of the declarations today."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "make_module_reference.py"


def _script() -> ModuleType:
    """The generator, loaded by path (scripts/ is no package; tests run with --import-mode=importlib)."""
    spec = importlib.util.spec_from_file_location("make_module_reference", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_module_reference_is_up_to_date() -> None:
    page = ROOT / "docs" / "modules.md"
    current = page.read_text(encoding="utf-8") if page.exists() else ""
    assert current == _script().render(), (
        "docs/modules.md is out of date with the modules' declarations: run "
        ".venv/bin/python scripts/make_module_reference.py and commit docs/modules.md")


def test_the_reference_lists_every_built_in_module_and_parameter() -> None:
    from objrec2d import HSVFilter
    from objrec3d import ShapeDetector

    script = _script()
    text = script.render()
    assert set(script.built_in_modules()) >= {"HSVFilter", "MorphologyFilter", "BinaryDetector", "FeatureDetector",
                                               "DistanceFilter", "VoxelFilter", "PlaneRemovalFilter", "ShapeDetector"}
    for cls in (HSVFilter, ShapeDetector):
        section = text.split(f"## {cls.type_name}\n", 1)[1].split("\n## ", 1)[0]
        for spec in cls.parameter_specs():
            assert f"| `{spec.name}` | {spec.type_name}" in section, spec.name
    assert "| `h_min` | int | `0` | int in 0..179 | Lowest hue kept" in text
