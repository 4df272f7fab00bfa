"""The limits and byte caps a user can run into are documented where the commands are: every limit of
strictio.limits, with its default and its environment variable, in the "Limits and exit codes" section of
docs/detect.md and of docs/navigation.md, and each command's byte caps with the sizes the code uses."""

from __future__ import annotations

from pathlib import Path

import pytest

from navigation.maps import MAP_YAML_LIMITS
from navigation.poses import POSE_FILE_LIMIT
from objrec3d.pcd import MAX_PCD_BYTES
from objrec_core.schema import PARAMETER_FILE_LIMITS
from strictio.limits import ALL_LIMITS

DOCS = Path(__file__).resolve().parents[2] / "docs"
SECTION = "## Limits and exit codes"


def section(doc: str) -> str:
    text = (DOCS / doc).read_text(encoding="utf-8")
    assert SECTION in text, f"docs/{doc} has no '{SECTION}' section"
    body = text.split(SECTION, 1)[1]
    return body.split("\n## ", 1)[0]


def size_text(size: int) -> str:
    """A byte cap as the documentation writes it: 32 MiB, 2 GiB."""
    for unit, factor in (("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if size % factor == 0:
            return f"{size // factor} {unit}"
    return f"{size:,} bytes"


@pytest.mark.parametrize("doc", ["detect.md", "navigation.md"])
def test_every_limit_is_documented_with_its_variable_and_default(doc: str) -> None:
    text = section(doc)
    missing = [f"{limit.name}: {what}" for limit in ALL_LIMITS
               for what in (limit.variable, f"{limit.default:,}") if what not in text]
    assert not missing, f"docs/{doc} '{SECTION}' lacks {missing}"


@pytest.mark.parametrize(("doc", "caps"), [
    ("detect.md", {"parameter file": PARAMETER_FILE_LIMITS.max_bytes, "PCD file": MAX_PCD_BYTES}),
    ("navigation.md", {"map YAML": MAP_YAML_LIMITS.max_bytes, "pose file": POSE_FILE_LIMIT}),
])
def test_byte_caps_are_documented_with_the_sizes_in_the_code(doc: str, caps: dict[str, int]) -> None:
    rows = [line for line in section(doc).splitlines() if line.startswith("|")]
    missing = [f"{kind} {size_text(size)}" for kind, size in caps.items()
               if not any(kind in row and size_text(size) in row for row in rows)]
    assert not missing, f"docs/{doc} '{SECTION}' has no table row giving {missing}"


@pytest.mark.parametrize("doc", ["detect.md", "navigation.md"])
def test_exit_codes_are_documented(doc: str) -> None:
    rows = [line for line in section(doc).splitlines() if line.startswith("| `")]
    codes = {row.split("`")[1] for row in rows}
    assert {"0", "1", "2", "130"} <= codes, f"docs/{doc} '{SECTION}' documents exit codes {sorted(codes)}"
