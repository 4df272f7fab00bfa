"""The hand-made label files of tests/data/labels, and docs/quality.md's real-data figures.

The label files read with the kinds' own readers and say what their README says; where ../shared/data is present,
each label lies on its picture or scan (a candy outline holds that candy's colour, the box outline the box, the
mug cylinder the mug's points), and every row of the page's real-data tables is what the library computes now,
so the page cannot go stale: change a detector and this test names the row and the figure to update.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from objrec_core import DetectedObjectArray, Frame, RecognitionSystem, build_system, get_kind, open_source
from objrec_core.evaluation import TruthSet, labelled_frames, score

ROOT = Path(__file__).resolve().parents[2]
LABELS = ROOT / "tests" / "data" / "labels"
PAGE = ROOT / "docs" / "quality.md"
SMARTIES = LABELS / "smarties.coco.json"
BOX = LABELS / "box_in_scene.coco.json"
MUG = LABELS / "table_scene_mug.truth.yaml"
#: The candies a person counts on smarties.png, by colour.
CANDIES = {"red": 4, "orange": 2, "green": 3, "blue": 3, "brown": 2}
#: box.png's printed face (its 2-3 px dark border left out), corners in the label's order.
BOX_FACE = np.float32([[2.5, 3.5], [320.5, 3.5], [320.5, 219.5], [2.5, 219.5]])


# -- the label files --------------------------------------------------------------------------------------------

def read(kind: str, path: Path) -> TruthSet:
    truth = get_kind(kind).read_truth(path)
    assert truth.kind == kind and truth.keyed_by == "index" and truth.indices == [0]
    return truth


def test_the_candy_labels_are_14_candies_by_colour_in_the_colour_systems_group() -> None:
    candies = read("2d", SMARTIES).frames[0].objects
    assert Counter(c.name for c in candies) == CANDIES
    assert {c.group for c in candies} == {"coloured_object"}  # what params/hsv_demo.yaml names its finds
    assert build_system(ROOT / "params" / "hsv_demo.yaml").object_name == "coloured_object"
    for candy in candies:
        points = np.array(candy.polygon)
        assert len(points) >= 8
        assert points.min() >= 0 and points[:, 0].max() <= 412 and points[:, 1].max() <= 355  # in the 413 x 356 photo
        assert 550 < candy.area < 2600, candy  # a candy some 54 px across, or the part of one the edge leaves


def test_the_box_label_is_a_convex_quadrilateral_of_the_box_face() -> None:
    (box,) = read("2d", BOX).frames[0].objects
    assert box.name == "box"
    corners = np.array(box.polygon, np.float32)
    assert corners.shape == (4, 2) and cv2.isContourConvex(corners)
    assert 15_000 < cv2.contourArea(corners) < 25_000  # box.png's face (318 x 216) at about half size


def test_the_mug_label_is_an_upright_cylinder_named_as_the_shape_system_names_it() -> None:
    (mug,) = read("3d", MUG).frames[0].objects
    assert (mug.name, mug.shape, mug.radius, mug.height) == ("cylinder", "cylinder", 0.040, 0.100)
    assert abs(np.linalg.norm(mug.axis) - 1.0) < 1e-9
    names = [d.object_name for d in build_system(ROOT / "params" / "shape_demo.yaml").detectors]
    assert "cylinder" in names
    pcl_centre = np.array([0.055, 0.065, 0.764])  # PCL's tutorial pipeline: its inliers' centroid on the axis
    offset = pcl_centre - np.array(mug.centre)
    along = offset @ np.array(mug.axis)
    assert np.linalg.norm(offset - along * np.array(mug.axis)) < 0.003  # near this axis (PCL's given to the mm)
    assert 0.005 < along < 0.012  # and higher on it: PCL's plane removal leaves it the upper wall


# -- the labels lie on the data ---------------------------------------------------------------------------------

HUE_OF: dict[str, Callable[[float, float], bool]] = {  # OpenCV's hue 0..179 and value 0..255 of a candy's middle
    "red": lambda h, v: (h <= 4 or h >= 170) and v > 150,
    "orange": lambda h, v: 5 <= h <= 20 and v > 150,
    "green": lambda h, v: 40 <= h <= 90,
    "blue": lambda h, v: 95 <= h <= 135,
    "brown": lambda h, v: v < 100,
}


@pytest.mark.realdata
def test_each_candy_outline_holds_its_candy_and_white_table_around(shared_data: Path) -> None:
    image = cv2.imread(str(shared_data / "images" / "smarties.png"))
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
    for candy in read("2d", SMARTIES).frames[0].objects:
        inside = np.zeros(image.shape[:2], np.uint8)
        cv2.fillPoly(inside, [np.round(np.array(candy.polygon)).astype(np.int32)], 1)
        ring = cv2.dilate(inside, np.ones((9, 9), np.uint8)) - cv2.dilate(inside, np.ones((5, 5), np.uint8))
        core = cv2.erode(inside, np.ones((5, 5), np.uint8)) > 0
        hue, value = np.median(hsv[..., 0][core]), np.median(hsv[..., 2][core])
        assert HUE_OF[candy.name](hue, value), (candy.name, hue, value)
        assert np.mean(hsv[..., 1][core] >= 60) >= 0.95  # coloured all over
        assert np.mean(hsv[..., 1][ring > 0] < 60) >= 0.75  # 2-4 px outside: mostly the white table


@pytest.mark.realdata
def test_the_box_outline_carries_box_png_onto_the_box(shared_data: Path) -> None:
    """box.png warped onto the labelled corners matches the scene where the box is seen (its left part); moved by
    4 px, it no longer does."""
    target = cv2.imread(str(shared_data / "images" / "box.png"), cv2.IMREAD_GRAYSCALE).astype(np.float32)
    scene = cv2.imread(str(shared_data / "images" / "box_in_scene.png"), cv2.IMREAD_GRAYSCALE).astype(np.float32)
    seen = np.zeros(target.shape, np.uint8)
    seen[10:200, 10:135] = 1  # the lettering and the label, left of the photo window: nothing hides them

    def correlation(corners: np.ndarray) -> float:
        warp = cv2.getPerspectiveTransform(BOX_FACE, corners.astype(np.float32))
        warped = cv2.warpPerspective(target, warp, scene.shape[::-1])
        mask = cv2.warpPerspective(seen, warp, scene.shape[::-1], flags=cv2.INTER_NEAREST) > 0
        a, b = warped[mask] - warped[mask].mean(), scene[mask] - scene[mask].mean()
        return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum()))

    corners = np.array(read("2d", BOX).frames[0].objects[0].polygon)
    assert correlation(corners) > 0.7
    assert correlation(corners + np.array([4, 0])) < 0.5 and correlation(corners + np.array([0, 4])) < 0.5


@pytest.mark.realdata
def test_the_mug_cylinder_runs_through_the_mugs_points(shared_data: Path) -> None:
    with open_source(str(shared_data / "clouds" / "table_scene_mug_stereo_textured.pcd"), "3d") as source:
        points = next(iter(source)).data.points
    points = points[np.isfinite(points).all(axis=1)].astype(float)
    (mug,) = read("3d", MUG).frames[0].objects
    axis = np.array(mug.axis)

    def on_wall(centre: np.ndarray, radius: float) -> int:
        offset = points - centre
        along = offset @ axis
        radial = np.linalg.norm(offset - np.outer(along, axis), axis=1)
        return int(np.sum((np.abs(along) <= mug.height / 2) & (np.abs(radial - radius) < 0.005)))

    centre = np.array(mug.centre)
    found = on_wall(centre, mug.radius)
    assert found > 10_000  # the wall facing the camera and the inside of the far wall, within 5 mm
    assert on_wall(centre, mug.radius + 0.01) < found / 3  # 1 cm too wide: few points
    assert on_wall(centre + np.array([0.02, 0, 0]), mug.radius) < found / 2  # 2 cm aside: fewer


# -- docs/quality.md's real-data tables ------------------------------------------------------------------------

def page_rows() -> dict[tuple[str, str], dict[str, str]]:
    """Every row of the page's tables that has a ``data`` or ``source`` column, keyed by (first cell, that cell),
    as column -> text."""
    rows: dict[tuple[str, str], dict[str, str]] = {}
    header: list[str] | None = None
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        if not line.startswith("|"):
            header = None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if header is None:
            header = cells
        elif not re.fullmatch(r"[-: ]*", "".join(cells)) and {"data", "source"} & set(header):
            row = dict(zip(header, cells, strict=True))
            rows[(cells[0], row.get("data", row.get("source", "")))] = row
    return rows


def hsv_system(**changes: Any) -> RecognitionSystem:
    system = build_system(ROOT / "params" / "hsv_demo.yaml")
    for name, value in changes.items():
        module = "blobs" if name == "border_blobs" else "colour"
        setattr(system.module(module), name, value)
    return system


def box_system(shared_data: Path) -> RecognitionSystem:
    """params/feature_demo.yaml with box.png selected whole as its target, as the page describes."""
    system = build_system(ROOT / "params" / "feature_demo.yaml")
    system.object_name = "box"
    system.module("poster").set_target(cv2.imread(str(shared_data / "images" / "box.png")))
    return system


REAL_ROWS: dict[tuple[str, str], tuple[str, str, str, Callable[[Path], RecognitionSystem]]] = {
    ("`params/hsv_demo.yaml`", "smarties.png"): ("2d", "images/smarties.png", "smarties.coco.json",
                                                 lambda data: hsv_system()),
    ("the same, `border_blobs: false` (the previous default)", "smarties.png"): (
        "2d", "images/smarties.png", "smarties.coco.json", lambda data: hsv_system(border_blobs=False)),
    ("the same, `v_min: 20`", "smarties.png"): (
        "2d", "images/smarties.png", "smarties.coco.json", lambda data: hsv_system(v_min=20)),
    ("`params/feature_demo.yaml`, target box.png", "box_in_scene.png"): (
        "2d", "images/box_in_scene.png", "box_in_scene.coco.json", box_system),
    ("`params/shape_demo.yaml`", "table_scene_mug_stereo_textured.pcd"): (
        "3d", "clouds/table_scene_mug_stereo_textured.pcd", "table_scene_mug.truth.yaml",
        lambda data: build_system(ROOT / "params" / "shape_demo.yaml")),
}


#: The 2D demo rows: (system, source) -> parameter file. The demos need no data and run in a few seconds of CPU
#: each; the 3D demo's row takes half a minute and is left to the command on the page.
DEMO_ROWS = {("`params/hsv_demo.yaml`", "`demo:seed=3,frames=100`"): "hsv_demo.yaml",
             ("`params/feature_demo.yaml`", "`demo:seed=3,frames=100`"): "feature_demo.yaml"}


def test_the_page_has_every_row_tested_here() -> None:
    rows = page_rows()
    missing = (set(REAL_ROWS) | set(DEMO_ROWS)) - set(rows)
    assert not missing, sorted(missing)


@pytest.mark.parametrize("key", list(DEMO_ROWS), ids=[a for a, _ in DEMO_ROWS])
def test_the_pages_2d_demo_figures_are_what_the_library_computes(key: tuple[str, str]) -> None:
    """The demo labels every frame with what it drew (``Kind.frame_truth``), as objrec-eval without --truth."""
    kind = get_kind("2d")
    spec = key[1].strip("`")
    with open_source(spec, "2d") as source:
        frames = [(frame, kind.frame_truth(frame)) for frame in source]
    evaluation = score(build_system(ROOT / "params" / DEMO_ROWS[key]), kind, frames)
    row = page_rows()[key]
    assert row["frames"] == str(evaluation.frames) == "100"
    (figures,) = [r for r in evaluation.summary_rows() if r["name"] == "all"]
    differ = {column: (row[column], text) for column, text in expected_cells("2d", figures).items()
              if row[column] != text}
    assert not differ, f"docs/quality.md, row {key}: (page, library) {differ}"


def polygon_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two convex polygons."""
    a32, b32 = a.astype(np.float32), b.astype(np.float32)
    inter, _ = cv2.intersectConvexConvex(a32, b32)
    return float(inter / (cv2.contourArea(a32) + cv2.contourArea(b32) - inter))


def expected_cells(kind: str, figures: dict[str, Any], truth: TruthSet | None = None,
                   found: list[DetectedObjectArray] | None = None) -> dict[str, str]:
    """The page's cells as the library's figures print them."""
    cells = {name: str(figures[name]) for name in ("truth", "detected", "tp", "fp", "fn")}
    cells.update({"F1": f"{figures['f1']:.3f}"})
    if kind == "2d":
        cells.update({"precision": f"{figures['precision']:.3f}", "recall": f"{figures['recall']:.3f}",
                      "AP": f"{figures['ap']:.3f}"})
        return cells
    cells.update({"centre error (mm)": f"{figures['centre_error_median'] * 1000:.1f}",
                  "radius error (mm)": f"{figures['radius_error_median'] * 1000:.1f}",
                  "axis error (°)": f"{figures['axis_error_median']:.2f}"})
    assert truth is not None and found is not None
    (mug,) = truth.frames[0].objects
    (cylinder,) = [o for array in found for o in array.objects if o.shape == "cylinder"]
    cells["height (cm), detected / labelled"] = f"{cylinder.box.height * 100:.1f} / {mug.height * 100:.1f}"
    return cells


@pytest.mark.realdata
@pytest.mark.parametrize("key", list(REAL_ROWS), ids=[f"{a} on {b}" for a, b in REAL_ROWS])
def test_the_pages_real_data_figures_are_what_the_library_computes(shared_data: Path, key: tuple[str, str]) -> None:
    kind_name, data, labels, make_system = REAL_ROWS[key]
    kind = get_kind(kind_name)
    truth = kind.read_truth(LABELS / labels)
    found: list[DetectedObjectArray] = []

    def keep(frame: Frame, objects: DetectedObjectArray) -> None:
        found.append(objects)

    with open_source(str(shared_data / data), kind_name) as source:
        evaluation = score(make_system(shared_data), kind, labelled_frames(source, truth), on_frame=keep)
    assert evaluation.frames == 1
    (figures,) = [row for row in evaluation.summary_rows() if row["name"] == "all"]
    row = page_rows()[key]
    expected = expected_cells(kind_name, figures, truth, found)
    differ = {column: (row[column], text) for column, text in expected.items() if row[column] != text}
    assert not differ, f"docs/quality.md, row {key}: (page, library) {differ}"
    if key[1] == "box_in_scene.png":  # the page's prose gives the outline's overlap with the labelled face too
        (box,) = [o for array in found for o in array.objects]
        stated = f"IoU {polygon_iou(np.array(box.polygon.xy()), np.array(truth.frames[0].objects[0].polygon)):.2f}"
        assert f"{stated} (polygons)" in PAGE.read_text(encoding="utf-8"), stated
