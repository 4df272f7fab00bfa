"""A third-party filter plugs in through an entry point with no change to objrec."""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from objrec_core import UnknownModuleError, module_type, module_type_names

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "objrec-invert-filter"


def _example_tests():
    """The example plug-in's own test module, so that the project's suite runs its tests too."""
    spec = importlib.util.spec_from_file_location("objrec_invert_example_tests", EXAMPLE / "test_objrec_invert.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


example_tests = _example_tests()
test_example_invert_filter_in_numbers = example_tests.test_invert_filter_in_numbers
test_example_invert_filter_conforms = example_tests.test_invert_filter_conforms

BUILT_IN = {
    "HSVFilter",
    "MorphologyFilter",
    "BinaryDetector",
    "FeatureDetector",
    "DistanceFilter",
    "VoxelFilter",
    "PlaneRemovalFilter",
    "ShapeDetector",
}


def test_built_in_modules_are_registered_by_entry_point():
    assert set(module_type_names()) >= BUILT_IN
    assert module_type("HSVFilter").__name__ == "HSVFilter"


def test_unknown_type_lists_the_known_ones():
    with pytest.raises(UnknownModuleError, match=r"unknown module type 'Nope' \(known: .*HSVFilter"):
        module_type("Nope")


def install_example(project_root, tmp_path):
    """Lay the example out as pip would: the module plus a dist-info folder with its entry points."""
    site = tmp_path / "site"
    site.mkdir()
    shutil.copy(project_root / "examples" / "objrec-invert-filter" / "objrec_invert.py", site)
    info = site / "objrec_invert_filter-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: objrec-invert-filter\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text("[objrec.modules]\nInvertFilter = objrec_invert:InvertFilter\n")
    return site


def test_example_plugin_runs_in_objrec_detect(project_root, tmp_path):
    site = install_example(project_root, tmp_path)
    params = tmp_path / "dark.yaml"
    params.write_text(
        "format_version: 1\nobject_name: dark_thing\nkind: 2d\npipeline:\n"
        "- {type: InvertFilter, id: invert, parameters: {threshold: 60}}\n"
        "- {type: MorphologyFilter, id: open}\n"
        "- {type: BinaryDetector, id: blobs, parameters: {min_contour_length: 100}}\n"
    )
    import cv2
    import numpy as np

    image = np.full((120, 160, 3), 220, np.uint8)
    cv2.circle(image, (50, 60), 20, (20, 20, 20), -1)
    cv2.rectangle(image, (100, 30), (140, 90), (30, 30, 30), -1)
    cv2.imwrite(str(tmp_path / "table.png"), image)
    env = {**os.environ, "PYTHONPATH": f"{site}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    result = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", str(params), "--source", str(tmp_path / "table.png")],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    objects = json.loads(result.stdout.splitlines()[0])["objects"]
    assert sorted(len(o["polygon"]["points"]) > 3 for o in objects) == [True, True]
    assert {o["name"] for o in objects} == {"dark_thing"}
