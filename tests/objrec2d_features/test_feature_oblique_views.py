"""Simulated oblique views of the target (``view_tilts``): ASIFT's sampling, keypoints mapped back to where
they came from, the lab's poster seen 60-65 degrees off its normal by every feature type, targets saved with
and without views loading, and the inspection lab's poster found from every side it can be seen from."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from objrec2d import FeatureDetector
from objrec2d.features import FEATURE_TYPES, corner_error, rect_corners, target_to_state, unavailable_reason
from objrec2d.features.geometry import project
from objrec2d.features.view_synthesis import render_view, to_target, turned_homography, view_angles
from objrec_core import Rect
from objrec_core.storage import build_system

ROOT = Path(__file__).resolve().parents[2]
LAB = ROOT / "examples" / "inspection_lab"
AVAILABLE = [t for t in FEATURE_TYPES if unavailable_reason(t) is None]


@pytest.fixture(scope="module")
def poster() -> np.ndarray:
    image = cv2.imread(str(LAB / "poster.png"))
    assert image is not None
    return image


def oblique(poster: np.ndarray, angle_deg: float, distance: float = 1.4) -> tuple[np.ndarray, np.ndarray]:
    """The 0.8 m wide poster ``distance`` m in front of a 640x480 camera (f 525 px), turned ``angle_deg`` about
    its vertical axis (a camera at its height, that far round to the side) on a grey wall; and its true corners."""
    height, width = poster.shape[:2]
    homography = turned_homography((width, height), angle_deg, distance)
    wall = np.full((480, 640, 3), 150, np.uint8)
    frame = cv2.warpPerspective(poster, homography, (640, 480), dst=wall, borderMode=cv2.BORDER_TRANSPARENT)
    return frame, project(homography, rect_corners(Rect(0, 0, width, height)))[0]


def test_the_views_are_asifts_sampling():
    assert view_angles(0) == []
    counts = [len(view_angles(n)) for n in range(4)]
    assert counts == [0, 4, 9, 17]  # 4 longitudes at t = 1.41, 5 at t = 2, 8 at t = 2.83
    tilts = sorted({round(t, 3) for t, _ in view_angles(3)})
    assert tilts == [1.414, 2.0, 2.828]
    assert [round(lon, 1) for t, lon in view_angles(2) if round(t, 6) == 2.0] == [0.0, 36.0, 72.0, 108.0, 144.0]
    assert view_angles(2, "sideways") == [(pytest.approx(math.sqrt(2)), 0.0), (pytest.approx(2.0), 0.0)]
    with pytest.raises(ValueError, match="view_tilts: expected 0 to 3, found 4"):
        view_angles(4)
    with pytest.raises(ValueError, match="view_longitudes: expected one of all, sideways, found 'up'"):
        view_angles(1, "up")


@pytest.mark.parametrize(("tilt", "longitude"), [(math.sqrt(2), 0.0), (2.0, 36.0), (2.0, 144.0)])
def test_a_views_keypoints_map_back_to_the_target_point_they_show(tilt, longitude):
    """A bright dot drawn in the target lies, in the simulated view, where the view's affine map puts it;
    the inverse map (what keypoints go through) brings it back to within a fraction of a pixel."""
    image = np.full((240, 320), 40, np.uint8)
    dots = [(60.0, 50.0), (250.0, 70.0), (160.0, 190.0)]
    for x, y in dots:
        cv2.circle(image, (int(x), int(y)), 3, 255, -1)
    mask = np.full(image.shape, 255, np.uint8)
    picture, view_mask, view = render_view(image, mask, tilt, longitude)
    assert view.tilt == tilt and view.longitude_deg == longitude
    for x, y in dots:
        expected = view.affine @ np.array([x, y, 1.0])
        cx, cy = (round(v) for v in expected)
        window = picture[cy - 6 : cy + 7, cx - 6 : cx + 7].astype(np.float64) - 40
        assert window.max() > 60 and view_mask[cy, cx] == 255
        ys, xs = np.mgrid[cy - 6 : cy + 7, cx - 6 : cx + 7]
        seen = np.array([(xs * window).sum(), (ys * window).sum()]) / window.sum()  # the dot's centroid
        assert np.hypot(*(seen - expected)) < 0.5
        [back] = to_target((cv2.KeyPoint(float(seen[0]), float(seen[1]), 7.0),), view)
        assert np.hypot(back.pt[0] - x, back.pt[1] - y) < 0.5 * tilt


@pytest.mark.parametrize("feature_type", AVAILABLE)
def test_the_poster_seen_60_to_65_degrees_off_its_normal_is_found(poster, feature_type):
    """Without views no type finds the poster at 65 degrees (only KAZE and BRISK at 60, BRISK 12.6 px off).
    With 2 tilts sideways every type finds it at 60, 62 and 65 degrees within 0.5 px (0.11-0.13, 0.40-0.41,
    0.37-0.38 px). ORB's keypoint fit alone is 8.2 px off at 60 degrees; the photometric alignment moves the far
    corner the 8 px back, which its inliers allow (test_feature_photometric_correction.py); a limit on the size
    of the move alone (2x reprojection_threshold) would refuse it and leave ORB 8.2 px off."""
    plain = FeatureDetector(feature_type=feature_type)
    plain.set_target(poster)
    frame, _ = oblique(poster, 65.0)
    assert len(plain.detect(frame)) == 0
    tilted = FeatureDetector(feature_type=feature_type, view_tilts=2, view_longitudes="sideways")
    tilted.set_target(poster)
    assert len(plain.target) < len(tilted.target) <= 3 * len(plain.target)
    for angle in (60.0, 62.0, 65.0):
        frame, truth = oblique(poster, angle)
        result = tilted.detect(frame)
        assert len(result) == 1, (angle, result.reason)
        assert corner_error(result.details[0].quadrilateral, truth) < 0.5, angle


def test_targets_saved_with_or_without_views_load_and_a_change_recomputes_the_target(poster, tmp_path):
    # The lab's poster file asks for 2 tilts sideways: 3 sets of ORB keypoints, more than max_features.
    lab = build_system(LAB / "params" / "poster_2d.yaml").modules[0]
    assert (lab.params.view_tilts, lab.params.view_longitudes) == (2, "sideways")
    assert len(lab.target) > 2 * lab.params.max_features
    # The same file as written before views existed (no view keys anywhere) loads, without views.
    document = yaml.safe_load((LAB / "params" / "poster_2d.yaml").read_text())
    parameters = document["pipeline"][0]["parameters"]
    del parameters["view_tilts"], parameters["view_longitudes"]
    assert set(document["pipeline"][0]["state"]["target"]["features"]) == {
        "type", "max_features", "orb_scale_factor", "orb_levels", "orb_fast_threshold"}
    older = tmp_path / "poster_before_views.yaml"
    older.write_text(yaml.safe_dump(document))
    plain = build_system(older).modules[0]
    assert plain.params.view_tilts == 0 and len(plain.target) <= plain.params.max_features + 10
    # A target saved by a detector with views loads into one without, and the other way round.
    state = lab.get_state()
    assert state is not None and state["target"]["features"] == target_to_state(plain.target)["features"]
    plain.apply_state(plain.prepare_state(state, plain.get_parameters()))
    assert len(plain.target) <= plain.params.max_features + 10
    # Setting view_tilts recomputes the target at once, from its stored image.
    before = len(plain.target)
    plain.set_parameters(view_tilts=1, view_longitudes="all")
    assert len(plain.target) > 3 * before
    assert "view_tilts=1, view_longitudes=all" in plain.target.config.describe()
    plain.set_parameters(view_tilts=0)
    assert len(plain.target) == before


def test_the_lab_poster_is_found_from_every_side_it_can_be_seen_from(tmp_path, capsys):
    """Before the views the poster was found in 48 of 63 frames (60 degrees off its normal: 1 of 5 distances,
    300 degrees: 1 of 2); with them in 21 of 21 views (63 of 63 frames with 3 frames a view)."""
    spec = importlib.util.spec_from_file_location("measure_lab_views", ROOT / "scripts" / "measure_lab_views.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = script
    spec.loader.exec_module(script)
    views = tmp_path / "v.json"
    assert script.main(["--objects", "poster", "--repeats", "1", "--views", str(views)]) == 0
    out = capsys.readouterr().out
    [poster_views] = json.loads(views.read_text())
    assert poster_views["params"] == ["poster_2d.yaml"]
    rendered = [v for v in poster_views["views"] if v["outcome"] != "blocked"]
    assert len(rendered) == 21 and all(v["outcome"] != "hidden" for v in rendered)
    found = sum(v["found"] for v in rendered)
    assert found >= 20  # at least 11 of 12 (21 of 21 measured)
    steep = [v for v in rendered if v["direction_deg"] in (60.0, 300.0)]
    assert len(steep) == 7 and sum(v["found"] for v in steep) >= 6
    assert "poster: found in" in out and "recall below 50 % from 0 of 5 directions" in out
