"""The HSV colour system: hue wrap-around, morphology, the binary detector, the demo scene's ground truth
and the real smarties photo."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from objrec2d import BinaryDetector, DemoSource, DetectedObject2DArray, HSVFilter, MorphologyFilter
from objrec_core import DetectionDirector, ParameterError, RecognitionSystem, build_system


def hsv_patch_image(hues: list[int]) -> np.ndarray:
    """One 40x40 fully saturated patch per hue, on black."""
    hsv = np.zeros((40, 40 * len(hues), 3), np.uint8)
    for i, h in enumerate(hues):
        hsv[:, 40 * i : 40 * (i + 1)] = (h, 255, 255)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)


def test_hue_range_wraps_around_zero_for_red():
    image = hsv_patch_image([175, 3, 90, 20])
    mask = HSVFilter(h_min=170, h_max=10, s_min=100, v_min=100).filter(image)
    assert mask.ndim == 2 and mask.dtype == np.uint8
    kept = [bool(mask[20, 40 * i + 20]) for i in range(4)]
    assert kept == [True, True, False, False]
    plain = HSVFilter(h_min=80, h_max=100).filter(image)
    assert [bool(plain[20, 40 * i + 20]) for i in range(4)] == [False, False, True, False]


def test_hsv_filter_accepts_a_mask_as_grey_input():
    mask = np.zeros((10, 10), np.uint8)
    mask[2:5, 2:5] = 255
    out = HSVFilter(v_min=200).filter(mask)
    assert out.sum() == 9 * 255


def test_morphology_opening_removes_specks_and_closing_fills_holes():
    mask = np.zeros((50, 50), np.uint8)
    mask[10:30, 10:30] = 255
    mask[40, 40] = 255  # a speck
    mask[20, 20] = 0  # a hole
    opened = MorphologyFilter(operation="open", kernel_size=3).filter(mask)
    closed = MorphologyFilter(operation="close", kernel_size=3).filter(mask)
    assert opened[40, 40] == 0 and opened[15, 15] == 255
    assert closed[20, 20] == 255
    assert MorphologyFilter(iterations=0).filter(mask) is mask


def test_binary_detector_bounds_contour_length_and_outlines_with_the_convex_hull():
    mask = np.zeros((200, 200), np.uint8)
    cv2.rectangle(mask, (20, 20), (59, 59), 255, -1)  # perimeter about 156
    cv2.rectangle(mask, (100, 100), (104, 104), 255, -1)  # perimeter about 16
    cv2.fillPoly(mask, [np.array([[120, 20], [180, 20], [150, 50], [180, 80], [120, 80]])], 255)  # concave
    found = BinaryDetector(min_contour_length=40, max_contour_length=1000).detect(mask)
    assert len(found) == 2
    by_x = sorted(found, key=lambda o: o.polygon.centroid()[0])
    assert by_x[0].polygon.area() == pytest.approx(39 * 39, rel=0.01)
    assert by_x[1].polygon.area() == pytest.approx(60 * 60, rel=0.02)  # the hull fills the notch
    colour = cv2.cvtColor(mask, cv2.COLOR_GRAY2BGR)
    assert len(BinaryDetector(min_contour_length=40).detect(colour)) == 2
    assert BinaryDetector(min_contour_length=500).detect(mask) == []


def test_binary_detector_declares_its_length_order_instead_of_checking_it_by_hand():
    (rule,) = BinaryDetector.parameter_rules()
    assert rule.describe() == "min_contour_length <= max_contour_length"
    detector = BinaryDetector(max_contour_length=100)
    with pytest.raises(ParameterError) as caught:
        detector.set_parameters(min_contour_length=200)
    assert str(caught.value) == (
        "BinaryDetector: parameter min_contour_length=200.0 is invalid: must be at most max_contour_length=100.0 "
        "(nothing could ever be found)"
    )
    assert (detector.min_contour_length, detector.max_contour_length) == (40.0, 100.0)
    detector.set_parameters(min_contour_length=100)  # equal is allowed
    # Hard bounds for big frames, a slider range for the usual ones, the same for both ends.
    for name in ("min_contour_length", "max_contour_length"):
        spec = BinaryDetector.parameter_spec(name)
        assert (spec.min, spec.max, spec.slider_range) == (0.0, 20000.0, (0.0, 5000.0))
    assert BinaryDetector(min_contour_length=8000.0, max_contour_length=12000.0).max_contour_length == 12000.0


def match_truth(array: DetectedObject2DArray, truth: dict, names: set[str] | None = None) -> list[float]:
    """Distance from each ground-truth centroid to the nearest detection; also checks the counts."""
    wanted = [t for t in truth["objects"] if names is None or t["name"] in names]
    centroids = [o.polygon.centroid() for o in array.objects]
    assert len(centroids) == len(wanted), (centroids, [t["centroid"] for t in wanted])
    return [min(np.hypot(cx - t["centroid"][0], cy - t["centroid"][1]) for cx, cy in centroids) for t in wanted]


def test_shipped_demo_parameters_find_every_demo_object_at_its_true_position(project_root):
    system = build_system(project_root / "params" / "hsv_demo.yaml")
    director = DetectionDirector(system)
    errors = []
    for frame in DemoSource(frames=60):
        array = director.process(frame)
        errors += match_truth(array, frame.truth)
        assert all(o.name == "coloured_object" for o in array.objects)
    assert len(errors) == 60 * 4
    assert max(errors) < 3.0


@pytest.mark.parametrize(
    ("name", "h_min", "h_max"), [("red", 170, 10), ("green", 45, 85), ("blue", 100, 130), ("yellow", 20, 35)]
)
def test_one_colour_range_finds_only_its_demo_object(name, h_min, h_max):
    system = RecognitionSystem(
        [HSVFilter(h_min=h_min, h_max=h_max, s_min=120, v_min=60), MorphologyFilter(), BinaryDetector()],
        object_name=name,
    )
    director = DetectionDirector(system)
    for frame in DemoSource(seed=5, frames=20):
        errors = match_truth(director.process(frame), frame.truth, {name})
        assert max(errors) < 3.0


def test_demo_is_deterministic_by_seed():
    a = next(iter(DemoSource(seed=3, frames=1)))
    b = next(iter(DemoSource(seed=3, frames=1)))
    c = next(iter(DemoSource(seed=4, frames=1)))
    assert np.array_equal(a.data, b.data) and not np.array_equal(a.data, c.data)
    assert a.data.shape == (480, 640, 3)


@pytest.mark.realdata
@pytest.mark.parametrize(("colour", "h_min", "h_max", "expected"), [("blue", 100, 130, 3), ("green", 45, 85, 3)])
def test_smarties_photo(shared_data, colour, h_min, h_max, expected):
    image = cv2.imread(str(shared_data / "images" / "smarties.png"))
    system = RecognitionSystem(
        [
            HSVFilter(h_min=h_min, h_max=h_max, s_min=120, v_min=60),
            MorphologyFilter(operation="open", kernel_size=5),
            BinaryDetector(min_contour_length=60, border_blobs=True),  # a candy is cut off by the edge
        ],
        object_name=colour,
    )
    array = DetectionDirector(system).process(image)
    assert len(array.objects) == expected
    for obj in array.objects:
        x, y = obj.polygon.centroid()
        b, g, r = image[round(y), round(x)].astype(int)
        assert (b > r + 40) if colour == "blue" else (g > r + 40 and g > b + 40)
        assert obj.polygon.area() > 500  # a candy (or the cut-off one at the border), not a speck
