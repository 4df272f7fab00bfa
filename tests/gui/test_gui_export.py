"""File > Export as Python script: the script written for each shipped parameter file, run on a recorded bag,
prints byte for byte the JSON Lines ``objrec-detect`` prints for the file on the same bag (a bag, because its
stamps are recorded: the live demo stamps frames with the wall clock)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from objrec_apps.define import starting_system

from .test_gui_bags import record_demo

DETECT = [sys.executable, "-m", "objrec_apps.detect"]
TOPICS = {"hsv": "/camera/color/image_raw", "feature": "/camera/color/image_raw", "shape": "/camera/depth/points"}
#: Objects per frame the shipped files find in the demo: four coloured objects, the poster, cylinder + sphere.
FOUND = {"hsv": 4, "feature": 1, "shape": 2}


@pytest.fixture(scope="module")
def bag(tmp_path_factory, project_root):
    path = tmp_path_factory.mktemp("export") / "demo.bag"
    assert record_demo(project_root, path, 3) == {"/camera/color/image_raw": 3, "/camera/depth/points": 3}
    return path


def run(command: list[str], cwd) -> str:
    done = subprocess.run(command, capture_output=True, text=True, cwd=cwd, timeout=180)
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("name", ["hsv", "feature", "shape"])
def test_the_exported_script_prints_what_objrec_detect_prints(make_gui, project_root, tmp_path, bag, name):
    params = project_root / "params" / f"{name}_demo.yaml"
    gui = make_gui(starting_system("hsv"), paused=True, wait=False)
    assert gui.files.load(params)
    script = tmp_path / f"{name}.py"
    assert gui.export_script(str(script))
    assert gui.message_area.messages()[-1] == (f"exported the pipeline as {script}: "
                                            f"run it with python {script.name} [SOURCE]")
    text = script.read_text()
    assert "objrec_apps" not in text and "PySide6" not in text  # standalone: the library API only
    spec = f"bag:{bag},topic={TOPICS[name]}"
    exported = run([sys.executable, str(script), spec], tmp_path)
    detected = run([*DETECT, str(params), "--source", spec, "--no-progress"], project_root)
    assert exported == detected
    lines = [json.loads(line) for line in exported.splitlines()]
    assert [len(line["objects"]) for line in lines] == [FOUND[name]] * 3
    assert lines[0]["header"]["stamp"]["secs"] > 0  # the bag's stamps, compared too


def test_a_pipeline_without_a_detector_is_not_exported(make_gui, tmp_path):
    system = starting_system("hsv")
    system.remove_module("blobs")
    gui = make_gui(system, paused=True, wait=False)
    assert not gui.export_script(str(tmp_path / "nothing.py"))
    assert not (tmp_path / "nothing.py").exists()
    assert gui.message_area.messages()[-1] == "nothing to export: the pipeline has no detector"
