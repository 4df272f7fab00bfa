"""objrec-detect end to end on the 3D demo."""

from __future__ import annotations

import json
import subprocess
import sys

import cv2


def test_objrec_detect_prints_the_demo_cylinder_and_sphere(project_root, tmp_path) -> None:
    out = tmp_path / "annotated"
    result = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", "params/shape_demo.yaml", "--source", "demo",
         "--max-frames", "2", "--annotate", str(out)],
        cwd=project_root, capture_output=True, text=True, timeout=240,
    )
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.strip()]
    assert len(lines) == 2
    for line in lines:
        shapes = sorted((o["name"], o["shape"]) for o in line["objects"])
        assert shapes == [("cylinder", "cylinder"), ("sphere", "sphere")]
        for o in line["objects"]:
            assert set(o["box"]) == {"pose", "width", "height", "depth"}
    images = sorted(out.iterdir())
    assert images and cv2.imread(str(images[0])).shape == (480, 640, 3)
