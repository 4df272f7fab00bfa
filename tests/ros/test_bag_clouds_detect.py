"""objrec-detect on a PointCloud2 bag finds exactly what the same clouds give from PCD files."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys

import pytest

from objrec3d import write_pcd
from objrec_core import open_source

pytest.importorskip("rosbags")


def detect(project_root, source):
    result = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", "params/shape_demo.yaml", "--source", str(source)],
        capture_output=True, text=True, cwd=project_root, timeout=300,
    )
    assert result.returncode == 0, result.stderr
    return [json.loads(line) for line in result.stdout.splitlines()]


@pytest.mark.parametrize("name", ["clouds.bag", "clouds_mcap"])
def test_a_cloud_bag_gives_the_objects_of_the_same_clouds_as_pcd_files(project_root, tmp_path, name):
    spec = importlib.util.spec_from_file_location("record_demo_bag", project_root / "scripts" / "record_demo_bag.py")
    recorder = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(recorder)
    bag = tmp_path / name
    assert recorder.record(bag, 2, ["3d"], 4) == {"/camera/depth/points": 2}
    folder = tmp_path / "pcd"
    folder.mkdir()
    for frame in open_source("demo:seed=4,frames=2", "3d"):
        write_pcd(folder / f"{frame.index}.pcd", frame.data, "binary")
    from_bag, from_files = detect(project_root, bag), detect(project_root, folder)
    assert [len(line["objects"]) for line in from_bag] == [2, 2]  # the demo's cylinder and sphere
    assert [line["objects"] for line in from_bag] == [line["objects"] for line in from_files]
    assert {line["header"]["frame_id"] for line in from_bag} == {"camera_depth_optical_frame"}
    stamps = [line["header"]["stamp"] for line in from_bag]
    assert stamps == [{"secs": 1_700_000_000, "nsecs": 0}, {"secs": 1_700_000_000, "nsecs": 33_333_333}]
