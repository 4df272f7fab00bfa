"""BinaryDetector: the background is not an object, a blob cut off by the frame edge is one flagged
``truncated`` (dropped only with ``border_blobs`` off), and when nothing is found the result's ``reason`` says
which rule dropped what."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec2d import BinaryDetector, DemoScene
from objrec_core import DetectionDirector, RecognitionSystem, build_system

WIDTH, HEIGHT = 640, 480


def mask() -> np.ndarray:
    return np.zeros((HEIGHT, WIDTH), np.uint8)


def test_the_whole_frame_is_not_an_object_at_defaults():
    full = np.full((HEIGHT, WIDTH), 255, np.uint8)
    detector = BinaryDetector()
    assert cv2.arcLength(np.array([[0, 0], [WIDTH - 1, 0], [WIDTH - 1, HEIGHT - 1], [0, HEIGHT - 1]]), True) == 2236
    assert detector.max_contour_length == 5000.0  # the outline is within the length range: the area rule drops it
    # Border blobs are kept by default, so the area rule keeps the background out (639 x 479 of 640 x 480).
    result = detector.detect(full)
    assert result == []
    assert result.reason == (
        "1 blob, none kept: 1 covering more than max_area_fraction 0.9 of the image (smallest 100%)"
    )
    # With border blobs off, the border rule drops it first.
    result = BinaryDetector(border_blobs=False).detect(full)
    assert result == []
    assert result.reason == "1 blob, none kept: 1 touching the image border (border_blobs is off)"
    # Both rules off: the old behaviour, one object of the whole frame.
    (whole,) = BinaryDetector(border_blobs=True, max_area_fraction=1.0).detect(full)
    assert whole.polygon.area() == pytest.approx(639 * 479)


@pytest.mark.parametrize(
    ("corner", "where"),
    [((0, 200), "left"), ((200, 0), "top"), ((WIDTH - 40, 200), "right"), ((200, HEIGHT - 40), "bottom")],
)
def test_a_blob_touching_any_border_is_kept_as_truncated_unless_border_blobs_is_off(corner, where):
    image = mask()
    x, y = corner
    cv2.rectangle(image, (x, y), (x + 39, y + 39), 255, -1)  # a 40 x 40 square flush with the {where} edge
    cv2.rectangle(image, (300, 200), (339, 239), 255, -1)  # and one clear of every edge
    both = BinaryDetector().detect(image)
    assert both.reason is None
    flags = {round(o.polygon.centroid()[0]): o.truncated for o in both}
    assert flags == {x + 20: True, 320: False}, where
    result = BinaryDetector(border_blobs=False).detect(image)
    (kept,) = result
    assert kept.polygon.centroid() == pytest.approx((319.5, 219.5)), where
    assert not kept.truncated and result.reason is None


def test_a_blob_one_pixel_from_the_border_is_kept():
    image = mask()
    cv2.rectangle(image, (1, 1), (40, 40), 255, -1)
    (kept,) = BinaryDetector(border_blobs=False).detect(image)
    assert not kept.truncated


def test_a_large_blob_clear_of_the_border_is_dropped_only_past_the_area_fraction():
    image = mask()
    cv2.rectangle(image, (10, 10), (WIDTH - 11, HEIGHT - 11), 255, -1)  # 620 x 460: 92.8 % of the image
    assert BinaryDetector(max_contour_length=20000.0).detect(image) == []
    detector = BinaryDetector(max_contour_length=20000.0, max_area_fraction=0.95)
    assert len(detector.detect(image)) == 1


def test_the_reason_names_each_rule_with_counts_and_the_nearest_value():
    image = mask()
    image[100, 100] = image[200, 300] = 255  # two specks: outlines of 0 px
    cv2.rectangle(image, (400, 100), (404, 104), 255, -1)  # outline 16 px
    cv2.rectangle(image, (0, 300), (59, 359), 255, -1)  # a border blob
    detector = BinaryDetector(border_blobs=False)
    result = detector.detect(image)
    assert result == []
    assert result.reason == (
        "4 blobs, none kept: 3 shorter than min_contour_length 40 px (longest 16 px), "
        "1 touching the image border (border_blobs is off)"
    )
    long_outline = BinaryDetector(min_contour_length=10.0, max_contour_length=12.0)
    result = long_outline.detect(image)
    assert result == []
    assert result.reason == (
        "4 blobs, none kept: 2 shorter than min_contour_length 10 px (longest 0 px), "
        "2 longer than max_contour_length 12 px (shortest 16 px)"
    )


def test_an_empty_mask_says_so_and_a_find_clears_the_reason():
    detector = BinaryDetector()
    result = detector.detect(mask())
    assert result == []
    assert result.reason == "no blob: the mask has no non-zero pixel (the filters before let nothing through)"
    image = mask()
    cv2.circle(image, (320, 240), 30, 255, -1)
    found = detector.detect(image)
    assert len(found) == 1 and found.reason is None


def test_the_parameters_say_what_they_do():
    spec = BinaryDetector.parameter_spec
    assert BinaryDetector().border_blobs is True
    assert "truncated" in spec("border_blobs").doc
    assert (spec("max_area_fraction").default, spec("max_area_fraction").min, spec("max_area_fraction").max) == (
        0.9, 0.0, 1.0)
    assert "2236 px" in spec("max_contour_length").doc and "drops the whole-image blob" not in spec(
        "max_contour_length").doc


def test_the_shipped_colour_file_loads_with_the_new_defaults_and_finds_its_four_objects(project_root):
    system = build_system(project_root / "params" / "hsv_demo.yaml")
    blobs = system.module("blobs")
    assert (blobs.border_blobs, blobs.max_area_fraction) == (True, 0.9)  # keys the file does not have
    director = DetectionDirector(system)
    for seed in (0, 3, 7):
        scene = DemoScene(seed=seed)
        for index in range(0, 300, 25):
            image, truth = scene.render(index)
            objects = director.process(image).objects
            assert len(objects) == len(truth["objects"]) == 4, (seed, index)


def test_a_truncated_object_says_so_in_its_json_line_and_reads_back():
    image = mask()
    cv2.circle(image, (10, 240), 30, 255, -1)  # a disc cut by the left edge
    cv2.circle(image, (320, 240), 30, 255, -1)
    system = RecognitionSystem([BinaryDetector(id="blobs")], object_name="disc")
    array = DetectionDirector(system).process(image)
    lines = json.loads(array.to_json())["objects"]
    assert sorted(("truncated" in line, line.get("truncated")) for line in lines) == [(False, None), (True, True)]
    back = type(array).from_json(array.to_json())
    assert sorted(o.truncated for o in back.objects) == [False, True]
    assert back.objects == array.objects


#: The smarties photo's candies cut by the frame edge (label boxes x, y, w, h of tests/data/labels/smarties.coco.json):
#: the green one at the right, the green and the orange one at the bottom.
CUT_CANDIES = {"green right": (360, 144, 52, 53), "green bottom": (0, 328, 37, 27), "orange bottom": (108, 300, 52, 55)}


@pytest.mark.realdata
def test_the_shipped_colour_system_finds_the_smarties_cut_by_the_frame_edge_and_flags_them(shared_data: Path,
                                                                                           project_root: Path):
    image = cv2.imread(str(shared_data / "images" / "smarties.png"))
    labels = json.loads((project_root / "tests" / "data" / "labels" / "smarties.coco.json").read_text())
    truth = {tuple(round(v) for v in a["bbox"]): np.array(a["segmentation"][0], np.float32).reshape(-1, 2)
             for a in labels["annotations"]}
    objects = DetectionDirector(build_system(project_root / "params" / "hsv_demo.yaml")).process(image).objects
    assert len(objects) == len(truth) == 14  # 12 candies, 2 highlights of the dark brown ones (v_min 60)

    def iou(a: np.ndarray, b: np.ndarray) -> float:
        inter, _ = cv2.intersectConvexConvex(a, cv2.convexHull(b).reshape(-1, 2))
        return inter / (cv2.contourArea(a) + cv2.contourArea(b) - inter)

    cut = {}
    for obj in objects:
        outline = np.array(obj.polygon.xy(), np.float32)
        box = max(truth, key=lambda b: iou(outline, truth[b]))
        if obj.truncated:
            cut[next(name for name, b in CUT_CANDIES.items() if b == box)] = iou(outline, truth[box])
        else:
            x, y, w, h = cv2.boundingRect(outline)
            assert x > 0 and y > 0 and x + w < image.shape[1] and y + h < image.shape[0]
    assert set(cut) == set(CUT_CANDIES)
    # The outlines are the visible parts, as the labels are: IoU 0.97-0.98 against the hand-drawn outlines.
    assert all(value > 0.95 for value in cut.values()), cut
