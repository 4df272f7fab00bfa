"""docs/architecture.md's table of packages and their imports matches the code, and the layers hold.

Every ``import`` of every module of a package (at the top or inside a function: a lazy import is still a
dependency) is read with ``ast``; the table's third column lists, in backticks, the project packages each one
imports. A new import between packages therefore changes the table in the same commit.
"""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "architecture.md"
PACKAGES = ("strictio", "declare", "rerunio", "foxgloveio", "objrec_core",
            "objrec2d", "objrec3d", "objrec_ros", "objrec_apps",
            "navigation")
_ROW = re.compile(r"^\|\s*`(\w+)`\s*\|[^|]*\|([^|]*)\|\s*$")


def imports_of(package: str) -> dict[str, set[str]]:
    """Top-level names each package imports, with the files that do (relative imports stay inside)."""
    found: dict[str, set[str]] = defaultdict(set)
    for path in sorted((ROOT / package).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found[name.split(".")[0]].add(str(path.relative_to(ROOT)))
    return found


def project_imports(package: str) -> dict[str, set[str]]:
    return {name: files for name, files in imports_of(package).items() if name in PACKAGES and name != package}


def table() -> dict[str, set[str]]:
    """The page's table: package -> the project packages its third column names."""
    rows = {}
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        match = _ROW.match(line)
        if match and match.group(1) in PACKAGES:
            rows[match.group(1)] = set(re.findall(r"`(\w+)`", match.group(2)))
    return rows


def test_the_table_lists_every_package() -> None:
    assert sorted(table()) == sorted(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_the_table_says_what_each_package_imports(package: str) -> None:
    actual = project_imports(package)
    shown = table()[package]
    missing = {name: sorted(files)[:3] for name, files in actual.items() if name not in shown}
    extra = shown - set(actual)
    assert not missing and not extra, (
        f"docs/architecture.md, row `{package}`: imported but not in the table: {missing}; "
        f"in the table but not imported: {sorted(extra)}")


@pytest.mark.parametrize(("package", "allowed"), [
    ("strictio", set()),
    ("declare", {"strictio"}),
    ("rerunio", {"strictio"}),
    ("foxgloveio", {"strictio"}),
    ("navigation", {"strictio", "declare", "rerunio", "foxgloveio"}),
])
def test_the_floor_and_navigation_import_no_objrec_package(package: str, allowed: set[str]) -> None:
    assert set(project_imports(package)) <= allowed, project_imports(package)


@pytest.mark.parametrize(("package", "forbidden"), [
    ("objrec_core", {"cv2", "open3d", "PySide6", "objrec2d", "objrec3d", "objrec_ros", "objrec_apps"}),
    ("objrec2d", {"PySide6", "objrec3d", "objrec_apps", "open3d"}),
    ("objrec3d", {"PySide6", "objrec2d", "objrec_apps"}),
    ("objrec_ros", {"PySide6", "objrec2d", "objrec3d", "objrec_apps"}),
    ("objrec_apps", {"objrec2d", "objrec3d"}),
    ("navigation", {"PySide6"}),
])
def test_the_layers_hold(package: str, forbidden: set[str]) -> None:
    imported = imports_of(package)
    broken = {name: sorted(imported[name])[:3] for name in forbidden & set(imported)}
    assert not broken, f"{package} imports {broken}"
