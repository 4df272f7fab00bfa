"""Declared fields: every reader names a wrong value deep in its file the same way.

One table: for each file objrec reads (world, map, goal poses, mission, the task options inside a mission, a
parameter file) a file with one wrong value in a nested record inside a list, and the exact one-line error it
must give: ``FILE:LINE: key.path: VALUE is invalid: RULE``. Then the commands themselves, each in a child
process, on such a file: exit code 2, one stderr line naming the line and key path, no traceback.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from declare.fields import DocumentError
from navigation.maps import load_map_metadata
from navigation.poses import load_poses
from navigation.world import load_world
from objrec_apps.inspection.mission import load_mission
from objrec_core import build_system
from strictio import InputError

from .harness import assert_refused, child_env, run

LAB = Path(__file__).resolve().parents[2] / "examples" / "inspection_lab"

POSES = "1, 1, 0, 0, 0, 0, 1\n2, 1, 0, 0, 0, 0, 1\n"


@dataclass(frozen=True)
class Case:
    """A file with one wrong value, the reader that reads it, and the message it must give."""

    name: str  # the file's name
    text: str
    read: Callable[[Path], Any]
    line: int
    key_path: str
    value: str  # as the message shows it
    rule: str

    @property
    def message(self) -> str:
        return f"{self.name}:{self.line}: {self.key_path}: {self.value} is invalid: {self.rule}"


CASES = [
    Case("lab.world.yaml",
         "objects:\n"
         "  - {name: can, shape: cylinder, x: 1.0, y: 1.0, radius: 0.05, height: 0.2}\n"
         "obstacles:\n"
         "  - name: walker\n"
         "    shape: cylinder\n"
         "    radius: 0.25\n"
         "    height: 1.7\n"
         "    speed: 0.4\n"
         "    path:\n"
         "      - [1.0, 1.0]\n"
         "      - [4.0, 7.0e+9]\n",
         load_world, 11, "obstacles[0].path[1][1]", "7000000000.0",
         "out of range, allowed float in -1000000..1000000"),
    Case("lab.yaml",
         "image: lab.pgm\nresolution: 0.05\norigin:\n  - 0.0\n  - 0.0\n  - 250.0\nmode: trinary\n",
         load_map_metadata, 6, "origin[2]", "250.0", "out of range, allowed float in -100..100"),
    Case("poses.txt",
         "# x, y, z, qx, qy, qz, qw\nstation_pose: 0, 0, 0, 0, 0, 0, 1\n1, 1, 0, 0, 0, 0, 1\n\n"
         "2, 1, 0, 0, 0, 0, 1\n3, 1, 0, 0, 0, nine, 1  # the third goal\n",
         load_poses, 6, "goals[2].qz", "'nine'", "expected a number"),
    Case("mission.yaml",
         "poses: poses.txt\n"
         "at:\n"
         "  1:\n"
         "    expect:\n"
         "      - a\n"
         "      - name: b\n"
         "        tolerance: -0.5\n",
         load_mission, 7, "at.1.expect[1].tolerance", "-0.5", "out of range, allowed float in (0..1000000]"),
    Case("tasks.yaml",
         "poses: poses.txt\n"
         "tasks:\n"
         "  - wait: 1\n"
         "at:\n"
         "  0:\n"
         "    tasks:\n"
         "      - photo\n"
         "      - look_around:\n"
         "          headings: [-20, 0,\n"
         "                     400]\n",
         load_mission, 10, "at.0.tasks[1].look_around.headings[2]", "400",
         "out of range, allowed float in -360..360"),
    Case("colour.yaml",
         "format_version: 1\n"
         "object_name: thing\n"
         "kind: 2d\n"
         "pipeline:\n"
         "- type: HSVFilter\n"
         "  id: colour\n"
         "  parameters: {h_min: 0, h_max: 179}\n"
         "- type: MorphologyFilter\n"
         "  id: open\n"
         "  parameters:\n"
         "    iterations: 1\n"
         "    kernel_size: 4\n"
         "- type: BinaryDetector\n"
         "  id: blobs\n",
         build_system, 12, "pipeline[1].parameters.kernel_size", "4",
         "not allowed, int in 1..31 in steps of 2 from 1"),
]


def write(folder: Path, case: Case) -> Path:
    (folder / "poses.txt").write_text(POSES, encoding="utf-8")
    path = folder / case.name
    path.write_text(case.text, encoding="utf-8")
    return path


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_a_wrong_value_deep_in_a_file_names_its_line_and_key_path(tmp_path: Path, case: Case):
    path = write(tmp_path, case)
    with pytest.raises(DocumentError) as info:
        case.read(path)
    error = info.value
    assert str(error) == f"{tmp_path}/{case.message}"
    assert (error.path, error.line, error.key_path) == (str(path), case.line, case.key_path)
    assert isinstance(error, InputError)  # the commands' one-line, exit-2 refusal


def by_name(name: str) -> Case:
    return next(c for c in CASES if c.name == name)


def command_cases() -> list[tuple[str, list[str], str]]:
    """(the file the command is given, its command line, the case whose message it must print)."""
    return [
        ("lab.yaml", ["objrec-patrol", "poses.txt", "--map", "lab.yaml", "--laps", "1"], "lab.yaml"),
        ("tasks.yaml", ["objrec-inspect", "tasks.yaml", "--map", str(LAB / "lab.yaml"), "--world",
                        str(LAB / "lab.world.yaml"), "--out", "out"], "tasks.yaml"),
        ("colour.yaml", ["objrec-detect", "colour.yaml", "--source", "demo", "--max-frames", "1"], "colour.yaml"),
    ]


@pytest.mark.parametrize(("name", "argv", "expected"), command_cases(), ids=["patrol", "inspect", "detect"])
def test_the_commands_print_that_one_line_and_exit_2(tmp_path: Path, name: str, argv: list[str], expected: str):
    write(tmp_path, by_name(name))
    outcome = run(argv, tmp_path, env=child_env())
    assert_refused(outcome, [name], outputs=[str(tmp_path / "out")])
    case = by_name(expected)
    assert f"{case.name}:{case.line}: {case.key_path}: {case.value} is invalid: {case.rule}" in outcome.stderr
    assert "Traceback" not in outcome.stderr
