"""scripts/measure_lab_views.py on one object of the lab: the views placed around it, the blocked ones, the
recall, the truth file of every frame rendered, the views file and the picture."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import cv2

from objrec_core import get_kind

ROOT = Path(__file__).resolve().parents[2]


def load_script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("measure_lab_views", ROOT / "scripts" / "measure_lab_views.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_the_blue_ball_is_found_from_every_side_it_can_be_seen_from(tmp_path, capsys):
    script = load_script()
    truth, views, picture = tmp_path / "t.yaml", tmp_path / "v.json", tmp_path / "p.png"
    assert script.main(["--objects", "blue_ball", "--repeats", "1", "--truth", str(truth), "--views", str(views),
                        "--picture", str(picture)]) == 0
    out = capsys.readouterr().out
    [ball] = json.loads(views.read_text())
    assert ball["params"] == ["shapes_3d.yaml"] and len(ball["views"]) == 12 * 5
    rendered = [v for v in ball["views"] if v["outcome"] != "blocked"]
    assert len(rendered) == 32 and all(v["tries"] == 1 and v["outcome"] != "hidden" for v in rendered)
    found = sum(v["found"] for v in rendered)
    assert found >= 30  # the sphere detector finds the ball from every side (32 of 32 in the full run)
    assert f"| all | **{found / 32:.0%}** ({found}/32 frames; 0 views hidden, 28 blocked) |" in out
    assert f"blue_ball: found in {found} of 32 frames of views in sight; recall below 50 % from 0 of 12 " in out
    # Every frame rendered is in the truth file, the view's first frame at the index the views file gives.
    labels = get_kind("3d").read_truth(truth)
    assert labels.indices == list(range(32))
    for v in rendered:
        [shape] = [o for o in labels.lookup(v["frame"]).objects if o.name == "blue_ball"]
        assert shape.visible_points == v["visible_points"]
        assert abs(shape.centre[2] - v["distance"]) < 1e-9 and abs(shape.centre[0]) < 1e-9  # straight ahead
    image = cv2.imread(str(picture))
    assert image.shape == (420 + 62, 2 * 420, 3)


def test_the_green_cylinder_is_found_from_every_side_plane_removal_leaves_its_face(tmp_path, capsys):
    """Before the plane checks it was found in 31 of 81 frames: the plane removal (max_planes 3) took the
    cylinder's front for a plane from 7 of its 9 reachable directions. At least 11 of 12 frames now, every side."""
    script = load_script()
    views = tmp_path / "v.json"
    assert script.main(["--objects", "green_cylinder", "--repeats", "1", "--views", str(views)]) == 0
    out = capsys.readouterr().out
    [cylinder] = json.loads(views.read_text())
    assert cylinder["params"] == ["cylinder_3d.yaml"]
    rendered = [v for v in cylinder["views"] if v["outcome"] != "blocked"]
    assert len(rendered) == 27 and all(v["outcome"] != "hidden" for v in rendered)
    found = sum(v["found"] for v in rendered)
    assert found * 12 >= 11 * len(rendered)  # 27 of 27 in the full run
    directions = {v["direction_deg"] for v in rendered}
    assert len(directions) == 9
    for direction in directions:  # from every side it can be seen from
        seen = [v for v in rendered if v["direction_deg"] == direction]
        assert sum(v["found"] for v in seen) * 2 > len(seen), direction
    assert "green_cylinder: found in" in out and "recall below 50 % from 0 of 9 directions" in out
