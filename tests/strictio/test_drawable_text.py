"""Text reaching OpenCV's drawing, a ROS field or a file is valid (a lone surrogate killed the process
with a segmentation fault inside ``cv2.putText``); one function per way out, used at every drawing site."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from declare.parameters import ParameterError, Str
from strictio.atomic import LineOutput, write_atomically
from strictio.shown import DRAWN_LENGTH, drawable, escape_controls, valid_text

PROJECT = Path(__file__).resolve().parents[2]
PACKAGES = ("objrec2d", "objrec3d", "objrec_apps", "navigation", "objrec_core", "objrec_ros", "foxgloveio")


@pytest.mark.parametrize(("text", "drawn"), [
    ("coloured_object", "coloured_object"),
    ("bad\udcffname", "bad\\xffname"),  # a byte of a file name that is not UTF-8
    ("x\ud800y", "x\\ud800y"),  # any other lone surrogate
    ("Müsli", "Musli"),  # the accent dropped, the letter kept
    ("中", "\\u4e2d"),  # OpenCV's Hershey fonts would draw "?"
    ("a\nb\x1b", "a\\nb\\x1b"),
])
def test_drawable_is_printable_ascii(text: str, drawn: str) -> None:
    assert drawable(text) == drawn
    assert drawn.isascii() and drawn.isprintable()


def test_drawable_is_short_and_keeps_names_apart() -> None:
    assert len(drawable("a" * 5000)) == DRAWN_LENGTH
    assert drawable("bad\udcffname") != drawable("bad\udcfename")


def test_valid_text_encodes_as_utf8_and_changes_nothing_else() -> None:
    assert valid_text("Müsli 中") == "Müsli 中"
    assert valid_text("bad\udcffname") == "bad\\xffname"
    valid_text("x\ud800y").encode("utf-8")
    assert escape_controls("path/\udcff.png") == "path/\\xff.png"


def test_putting_a_lone_surrogate_through_drawable_does_not_crash_opencv() -> None:
    """In a child: without drawable this is exit -11 (SIGSEGV) with nothing on stderr."""
    code = ("import numpy as np, cv2\nfrom strictio.shown import drawable\n"
            "img = np.zeros((40, 200, 3), np.uint8)\n"
            "text = drawable('bad\\udcffname')\n"
            "cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1)\n"
            "cv2.putText(img, text, (2, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1)\n"
            "print(int(img.sum() > 0))\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert (result.returncode, result.stdout.strip()) == (0, "1"), result.stderr


def _text_arguments() -> list[tuple[str, int, ast.expr]]:
    """The text argument of every cv2.putText and cv2.getTextSize call in the project's packages."""
    found = []
    for package in PACKAGES:
        for path in sorted((PROJECT / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                        node.func.attr in ("putText", "getTextSize") and node.args:
                    index = 1 if node.func.attr == "putText" else 0
                    found.append((f"{path.relative_to(PROJECT)}:{node.lineno}", index, node.args[index]))
    return found


def test_every_drawing_site_passes_its_text_through_drawable() -> None:
    """A literal is drawn as written; anything computed goes through strictio.shown.drawable."""
    sites = _text_arguments()
    assert len(sites) >= 30  # the drawing sites: annotations, debug views, evaluation pictures, maps
    bare = [where for where, _, arg in sites
            if not (isinstance(arg, ast.Constant) and isinstance(arg.value, str) and arg.value.isascii())
            and not (isinstance(arg, ast.Call) and getattr(arg.func, "id", "") == "drawable")]
    assert not bare, f"text drawn without strictio.shown.drawable: {bare}"


def test_a_str_parameter_refuses_a_lone_surrogate_in_one_line() -> None:
    parameter = Str("name")
    parameter.bind("label", "Module")
    with pytest.raises(ParameterError) as caught:
        parameter.validate_value("bad\udcffname", "blobs")
    assert "lone surrogate" in str(caught.value) and "\n" not in str(caught.value)
    assert parameter.validate_value("Müsli", "blobs") == "Müsli"


def test_text_files_are_written_as_valid_utf8(tmp_path: Path) -> None:
    write_atomically(tmp_path / "report.md", "mission m\udcffission.yaml\n")
    assert (tmp_path / "report.md").read_text(encoding="utf-8") == "mission m\\xffission.yaml\n"
    with LineOutput.create(tmp_path / "events.jsonl") as lines:
        lines.write("name \udcff\n")
    assert (tmp_path / "events.jsonl").read_text(encoding="utf-8") == "name \\xff\n"
