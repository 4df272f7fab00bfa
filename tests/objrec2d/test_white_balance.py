"""WhiteBalanceFilter and the lighting set: a colour system survives colour casts with the filter in front.

The casts are a black body's colour relative to the light the camera is balanced for (objrec2d.lighting);
the figures are those of scripts/measure_white_balance.py, which docs/quality.md quotes.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from objrec2d import DemoSource
from objrec2d.lighting import DAYLIGHT_K, TUNGSTEN_K, blackbody_bgr, cast_gains, colour_cast
from objrec2d.white_balance_filter import WhiteBalanceFilter
from objrec_core import Frame, RecognitionSystem, build_system, get_kind
from objrec_core.evaluation import score
from objrec_core.registry import module_type


def test_the_casts_follow_the_colour_temperature():
    np.testing.assert_allclose(cast_gains(DAYLIGHT_K), [1.0, 1.0, 1.0])
    warm, cool = cast_gains(2500), cast_gains(12000)
    assert warm[0] < 0.6 and warm[2] > 1.4  # a bulb: less blue, more red
    assert cool[0] > 1.2 and cool[2] < 0.95  # an overcast sky: more blue
    tungsten_preset = cast_gains(DAYLIGHT_K, TUNGSTEN_K)
    assert tungsten_preset[0] / tungsten_preset[2] > 1.8  # daylight through a tungsten preset: strongly blue
    with pytest.raises(ValueError, match="kelvin 500"):
        blackbody_bgr(500)


@pytest.mark.parametrize("method", WhiteBalanceFilter.METHODS)
@pytest.mark.parametrize(("kelvin", "camera"), [(2500, DAYLIGHT_K), (12000, DAYLIGHT_K), (9000, TUNGSTEN_K)])
def test_a_cast_grey_scene_comes_back_grey(method, kelvin, camera):
    rng = np.random.default_rng(3)
    grey = rng.integers(30, 100, (120, 160), dtype=np.uint8)
    scene = cv2.merge([grey, grey, grey])
    scene[10:30, 10:30] = 130  # a white patch for white_patch to find, not clipped by the cast (gains up to 1.9)
    cast = colour_cast(scene, kelvin, camera)
    blue_over_red = cast[..., 0].mean() / cast[..., 2].mean()
    assert abs(blue_over_red - 1.0) > 0.2  # the cast is there
    balanced = WhiteBalanceFilter(method=method).filter(cast)
    b, g, r = (balanced[40:, 40:, c].astype(float).mean() for c in range(3))
    assert max(b, g, r) / min(b, g, r) < 1.06, (b, g, r)


def test_a_mask_passes_through_and_the_gains_are_bounded():
    mask = np.zeros((10, 10), np.uint8)
    assert WhiteBalanceFilter().filter(mask) is mask
    red = np.zeros((10, 10, 3), np.uint8)
    red[..., 2] = 200
    red[..., :2] = 2  # no grey at all: gray world would scale blue and green 60x
    gains = WhiteBalanceFilter(max_gain=4.0).gains(red)
    assert gains.max() == pytest.approx(4.0) and gains.min() >= 0.25


def test_the_filter_is_a_registered_module_with_declared_parameters():
    assert module_type("WhiteBalanceFilter") is WhiteBalanceFilter
    spec = WhiteBalanceFilter.parameter_spec
    assert spec("method").default == "gray_world"
    assert (spec("white_percentile").min, spec("white_percentile").max) == (50.0, 100.0)
    assert WhiteBalanceFilter(method="gray_world").relevant_parameters() == ["method", "max_gain"]


def shipped_with_balance(project_root: Path, method: str | None) -> RecognitionSystem:
    system = build_system(project_root / "params" / "hsv_demo.yaml")
    if method is not None:
        system.add_module(WhiteBalanceFilter(id="white_balance", method=method), 0)
    return system


def found_and_false(system: RecognitionSystem, labelled: list) -> tuple[int, int]:
    (row,) = [r for r in score(system, get_kind("2d"), labelled).summary_rows() if r["name"] == "all"]
    return int(row["tp"]), int(row["fp"])


def demo_scenes(seeds: range, kelvin: float, camera: float) -> list:
    kind = get_kind("2d")
    labelled = []
    for seed in seeds:
        with DemoSource(seed=seed, frames=1) as source:
            frame = next(iter(source))
        cast = Frame(colour_cast(frame.data, kelvin, camera), index=frame.index, truth=frame.truth)
        labelled.append((cast, kind.frame_truth(frame)))
    return labelled


@pytest.mark.parametrize(("kelvin", "camera", "without"), [
    (DAYLIGHT_K, TUNGSTEN_K, (3, 1225)),  # daylight through a tungsten preset: the grey background turns blue
    (2500, DAYLIGHT_K, (0, 0)),  # a bulb through a daylight preset: the whole frame passes, dropped by area
])
@pytest.mark.parametrize("method", WhiteBalanceFilter.METHODS)
def test_the_colour_system_survives_the_casts_of_the_demo_with_the_filter(project_root, kelvin, camera, without,
                                                                            method):
    labelled = demo_scenes(range(3), kelvin, camera)
    assert found_and_false(shipped_with_balance(project_root, None), labelled) == without
    assert found_and_false(shipped_with_balance(project_root, method), labelled) == (12, 0)


@pytest.mark.realdata
def test_the_candies_under_a_cool_light_through_a_tungsten_preset(shared_data, project_root):
    kind = get_kind("2d")
    truth = kind.read_truth(project_root / "tests" / "data" / "labels" / "smarties.coco.json")
    image = colour_cast(cv2.imread(str(shared_data / "images" / "smarties.png")), 12000, TUNGSTEN_K)
    labelled = [(Frame(image, index=0), truth.frames[0])]
    assert found_and_false(shipped_with_balance(project_root, None), labelled) == (10, 5)
    # Balanced, as in daylight (12 found, 2 false: the dark brown candies' highlights, v_min 60).
    assert found_and_false(shipped_with_balance(project_root, "gray_world"), labelled) == (12, 2)
    assert found_and_false(shipped_with_balance(project_root, "white_patch"), labelled) == (12, 2)
