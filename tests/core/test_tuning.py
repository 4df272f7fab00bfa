"""objrec_core.tuning: the search space comes from the declarations (bounds, steps, choices, None, relevance,
untuned, fixed names), the conformance check holds a module's declarations to it, and the search keeps its
promises (rules, fixed values, one seed one result, stop, held-out frames, the caller's system untouched).

The colour demo reaching F1 >= 0.95 from bad thresholds is in tests/apps/test_tune_cli.py (through the command).
"""

from __future__ import annotations

import math
import random
import sys
import threading

import pytest

from objrec2d import BinaryDetector, FeatureDetector, HSVFilter, ImageFilter, MorphologyFilter
from objrec_core import Float, Int, RecognitionSystem, Str, get_kind, module_type, module_type_names, open_source
from objrec_core.conformance import cases, run_case
from objrec_core.tuning import (
    NEEDS_EXTRA,
    SearchSpaceError,
    TuningError,
    TuningUnavailable,
    module_dimensions,
    search_space,
    tune,
)
from objrec_core.tuning.space import trial_values

pytest.importorskip("optuna")

MODULES_2D = [HSVFilter, MorphologyFilter, BinaryDetector, FeatureDetector]


def _shape_detector():
    pytest.importorskip("open3d")
    from objrec3d import ShapeDetector

    return ShapeDetector


def _expected_range(spec):
    """The searched range a number declaration promises: its soft bounds, an excluded end one step inside."""
    low, high = spec.soft_min, spec.soft_max
    if isinstance(spec, Int):
        low = low + 1 if spec.min_open and low == spec.min else low
        return spec.snap_to_step(int(low), down=False), spec.snap_to_step(int(high), down=True)
    inward = spec.step or (high - low) * 1e-6
    low = low + inward if spec.min_open and low == spec.min else low
    return float(low), float(high)


@pytest.mark.parametrize("name", ["HSVFilter", "MorphologyFilter", "BinaryDetector", "FeatureDetector",
                                  "ShapeDetector"])
def test_the_space_is_the_declarations(name):
    cls = _shape_detector() if name == "ShapeDetector" else module_type(name)
    dims = {d.parameter: d for d in module_dimensions(cls)}
    searched = [s for s in cls.parameter_specs() if not isinstance(s, Str) and s.name not in cls.untuned]
    assert set(dims) == {s.name for s in searched}  # a seed or a display switch (untuned) is kept, not searched
    for spec in searched:
        dim = dims[spec.name]
        if dim.kind == "choice":
            expected = (False, True) if spec.type_name == "bool" else spec.available_choices
            assert dim.choices == tuple(expected) + ((None,) if spec.optional else ())
            continue
        low, high = _expected_range(spec)
        assert dim.low == low, spec.name
        if dim.step and dim.kind == "float":  # a float grid ends on the last step inside the range
            assert high - dim.step < dim.high <= high, spec.name
        else:
            assert dim.high == high, spec.name
        if isinstance(spec, Int):
            assert dim.step == (spec.enforced_step or 1)
        assert dim.none_switch == spec.optional
        assert dim.conditional == (spec.relevant is not None)


def test_the_space_in_numbers():
    """Spot checks with the declarations' own numbers."""
    hsv = {d.parameter: d for d in module_dimensions(HSVFilter)}
    assert (hsv["h_min"].kind, hsv["h_min"].low, hsv["h_min"].high, hsv["h_min"].step) == ("int", 0, 179, 1)
    morph = {d.parameter: d for d in module_dimensions(MorphologyFilter)}
    assert (morph["kernel_size"].low, morph["kernel_size"].high, morph["kernel_size"].step) == (1, 31, 2)
    assert morph["operation"].choices == ("erode", "dilate", "open", "close")
    blobs = {d.parameter: d for d in module_dimensions(BinaryDetector)}
    # soft_max 5000 (the slider's), not the hard 20000: a search looks where a person would
    assert (blobs["min_contour_length"].low, blobs["min_contour_length"].high) == (0.0, 5000.0)
    assert blobs["border_blobs"].choices == (False, True)
    feature = {d.parameter: d for d in module_dimensions(FeatureDetector)}
    ratio = feature["ratio"]
    assert (ratio.low, ratio.high, ratio.step, ratio.log, ratio.conditional) == (0.1, 1.0, 0.05, False, True)
    assert feature["akaze_threshold"].log and feature["akaze_threshold"].low == 0.00001
    assert feature["max_features"].step == 10 and feature["max_features"].low == 10
    shape = {d.parameter: d for d in module_dimensions(_shape_detector())}
    radius = shape["normal_radius"]  # optional, min 0 excluded, step 0.001: None or 0.001..0.05
    assert (radius.low, radius.high, radius.none_switch) == (0.001, 0.05, True)


def test_a_drawn_float_sits_on_its_step_grid():
    ratio = next(d for d in module_dimensions(FeatureDetector) if d.parameter == "ratio")
    rng = random.Random(5)
    values = {ratio.sample(rng) for _ in range(200)}
    assert values <= {round(0.1 + 0.05 * k, 2) for k in range(19)}
    assert ratio.snap(0.7500000000000001) == 0.75 and ratio.snap(0.76) == 0.75 and ratio.snap(3.0) == 1.0
    akaze = next(d for d in module_dimensions(FeatureDetector) if d.parameter == "akaze_threshold")
    assert akaze.log and akaze.snap(0.0012345678) == 0.00123 and akaze.snap(1.0) == 0.1


def test_fix_search_and_kept_reasons():
    system = RecognitionSystem([HSVFilter(id="colour"), MorphologyFilter(id="open"), BinaryDetector(id="blobs")])
    space = search_space(system.modules, fix=["colour.h_min", "open"])
    assert "colour.h_min" not in space.keys and "colour.h_max" in space.keys
    assert not any(k.startswith("open.") for k in space.keys)
    assert space.kept["colour.h_min"] == "fixed" and space.kept["open.kernel_size"] == "fixed"
    only = search_space(system.modules, search=["blobs.min_contour_length", "colour.h_max"])
    assert only.keys == ["colour.h_max", "blobs.min_contour_length"]
    assert only.kept["colour.s_min"] == "not searched"
    with pytest.raises(SearchSpaceError, match=r"--fix 'colour\.h_mni': no such module parameter .*colour\.h_min"):
        search_space(system.modules, fix=["colour.h_mni"])
    with pytest.raises(SearchSpaceError, match="--search 'nothing'"):
        search_space(system.modules, search=["nothing"])


class _Labelled(ImageFilter):
    """A plug-in filter with a text parameter, an untuned one and a tunable one."""

    type_name = "_LabelledFilterForTuning"
    caption = Str("x", "text, never searched")
    seed = Int(0, "a seed", min=0, max=2**31 - 1)
    gain = Float(1.0, "gain", min=0.0, max=4.0)
    untuned = {"seed": "a seed is no setting"}  # noqa: RUF012 - a declaration

    def filter(self, frame):
        return frame


def test_untuned_and_text_parameters_are_kept():
    space = search_space([_Labelled(id="f")])
    assert space.keys == ["f.gain"]
    assert space.kept == {"f.caption": "text is not searched", "f.seed": "untuned: a seed is no setting"}


def test_relevance_decides_what_is_drawn():
    detector = FeatureDetector(id="features")
    space = search_space([detector], search=["features.ratio_test", "features.ratio"])
    start = {"features": detector.get_parameters()}
    for forced, drawn_ratio in ((False, False), (True, True)):
        drawn = []

        def draw(dim, current, forced=forced, drawn=drawn):
            drawn.append(dim.parameter)
            return forced if dim.parameter == "ratio_test" else 0.55

        values = trial_values(space, start, draw)
        assert ("ratio" in drawn) == drawn_ratio
        assert values["features"]["ratio"] == (0.55 if drawn_ratio else start["features"]["ratio"])


# -- the conformance check ------------------------------------------------------------------------------------
class _Unbounded(ImageFilter):
    type_name = "_UnboundedForTuning"
    gain = Float(1.0, "gain with no upper bound", min=0.0)

    def filter(self, frame):
        return frame


class _UntunedTypo(ImageFilter):
    type_name = "_UntunedTypoForTuning"
    gain = Float(1.0, "gain", min=0.0, max=2.0)
    untuned = {"gian": "typo"}  # noqa: RUF012 - a declaration

    def filter(self, frame):
        return frame


def _space_case(cls):
    (case,) = [c for c in cases(cls) if c.id.endswith("::search-space")]
    return case


def test_conformance_refuses_an_unbounded_float_in_one_line():
    with pytest.raises(AssertionError) as caught:
        run_case(_space_case(_Unbounded))
    text = str(caught.value)
    assert "\n" not in text
    assert text.startswith("_UnboundedForTuning [search space]: ")
    assert "parameter gain (float in 0..inf) has no upper bound to search" in text


def test_conformance_refuses_untuned_names_that_are_not_parameters():
    with pytest.raises(AssertionError, match="untuned names 'gian', which is no declared parameter"):
        run_case(_space_case(_UntunedTypo))


def test_conformance_accepts_a_bounded_module_and_its_untuned_names():
    run_case(_space_case(_Labelled))


def test_every_shipped_module_makes_a_usable_space():
    for name in module_type_names():
        cls = module_type(name)
        if cls.kind == "3d":
            pytest.importorskip("open3d")
        run_case(_space_case(cls))


# -- the search -------------------------------------------------------------------------------------------------
BAD_COLOUR = {"h_min": 140, "h_max": 160, "s_min": 10, "s_max": 255, "v_min": 0, "v_max": 255}


def bad_colour_system() -> RecognitionSystem:
    """The colour demo's pipeline with its hue range on a colour no demo object has (magenta)."""
    return RecognitionSystem([HSVFilter(id="colour", **BAD_COLOUR), MorphologyFilter(id="open"),
                              BinaryDetector(id="blobs")], object_name="coloured_object", kind="2d")


@pytest.fixture(scope="module")
def demo_frames():
    """40 demo frames with their own truth (the shapes in the group the colour system reports)."""
    kind = get_kind("2d")
    with open_source("demo:frames=40", "2d") as source:
        frames = [(frame, kind.frame_truth(frame)) for frame in source]
    assert all(label is not None and label.objects for _, label in frames)
    return frames


def test_rules_are_respected_and_the_sampler_told(demo_frames):
    system = bad_colour_system()
    system.module("colour").set_parameters(h_min=100, h_max=130, s_min=120, v_min=60)
    result = tune(system, "2d", demo_frames, 30, seed=1, search=["blobs.min_contour_length",
                                                                 "blobs.max_contour_length"])
    broken = [r for r in result.history if r.broken]
    assert broken, "a search over two ordered lengths never tried an unordered pair"
    for record in result.history:
        low, high = record.values["blobs.min_contour_length"], record.values["blobs.max_contour_length"]
        assert (record.broken is not None) == (low > high)
        if record.broken:
            assert record.score == 0.0 and "must be at most max_contour_length" in record.broken
    assert result.broken == len(broken)
    assert result.values["blobs.min_contour_length"] <= result.values["blobs.max_contour_length"]


def test_a_fixed_parameter_keeps_its_value(demo_frames):
    result = tune(bad_colour_system(), "2d", demo_frames, 15, seed=0, fix=["colour.h_min", "open"])
    assert result.values["colour.h_min"] == 140
    assert result.system.module("colour").h_min == 140
    assert result.system.module("open").get_parameters() == MorphologyFilter().get_parameters()
    assert all("colour.h_min" not in r.values and "open.iterations" not in r.values for r in result.history)
    assert any(r.values["colour.h_max"] != 160 for r in result.history)


def test_one_seed_gives_one_result(demo_frames):
    first = tune(bad_colour_system(), "2d", demo_frames, 20, seed=7)
    again = tune(bad_colour_system(), "2d", demo_frames, 20, seed=7)
    other = tune(bad_colour_system(), "2d", demo_frames, 20, seed=8)
    assert first.values == again.values and first.history == again.history
    assert first.importance == again.importance and first.score == again.score
    assert [r.values for r in other.history] != [r.values for r in first.history]


def test_held_out_frames_are_split_once_and_scored_once(demo_frames):
    seen = []
    kind = get_kind("2d")
    scorer = kind.scorer

    class Counting:
        name = "2d"

        def scorer(self, **options):
            made = scorer(**options)
            add = made.add
            made.add = lambda truth, detections, frame=None: (seen.append(truth.index), add(truth, detections,
                                                                                             frame))[1]
            return made

    result = tune(bad_colour_system(), Counting(), demo_frames, 4, seed=3, held_out=0.3)  # type: ignore[arg-type]
    assert (result.searched_frames, result.held_out_frames) == (28, 12)
    held = set(seen[-12:])
    searched = set(seen[:-12])
    assert len(held) == 12 and len(searched) == 28 and not held & searched
    # every trial scores the searched frames (but one that broke a rule: it is not run); the held-out ones once
    assert len(seen) == (4 - result.broken) * 28 + 12
    assert result.score == result.held_out_score


def test_none_held_out_reports_the_searched_score(demo_frames):
    result = tune(bad_colour_system(), "2d", demo_frames, 3, seed=0, held_out=0.0)
    assert result.held_out is None and (result.searched_frames, result.held_out_frames) == (40, 0)
    assert result.score == result.searched_score
    assert result.score_line() == f"score {result.score:.3f} on 40 searched frames (none held out)"


def test_the_callers_system_never_changes(demo_frames):
    system = bad_colour_system()
    before = {m.id: m.get_parameters() for m in system.modules}
    result = tune(system, "2d", demo_frames, 10, seed=0)
    assert {m.id: m.get_parameters() for m in system.modules} == before
    assert result.system is not system and result.system.modules[0] is not system.modules[0]


def test_stop_ends_after_the_trial_under_way_and_keeps_the_best(demo_frames):
    stop = threading.Event()
    heard = []

    def progress(update):
        heard.append(update)
        if update.trial == 3:
            stop.set()

    result = tune(bad_colour_system(), "2d", demo_frames, 50, seed=0, stop=stop, progress=progress)
    assert result.stopped and result.trials == 3 and [u.trial for u in heard] == [1, 2, 3]
    assert all(u.trials == 50 for u in heard)
    assert result.held_out is not None and result.held_out.frames == 12


def test_searches_that_cannot_start(demo_frames):
    with pytest.raises(TuningError, match="nothing to search"):
        tune(bad_colour_system(), "2d", demo_frames, 5, fix=["colour", "open", "blobs"])
    with pytest.raises(TuningError, match=r"held-out share 1\.0 must be at least 0 and below 1"):
        tune(bad_colour_system(), "2d", demo_frames, 5, held_out=1.0)
    with pytest.raises(TuningError, match="no labelled frames"):
        tune(bad_colour_system(), "2d", [], 5)


def test_without_optuna_one_line_says_what_to_install(monkeypatch, demo_frames):
    monkeypatch.setitem(sys.modules, "optuna", None)
    with pytest.raises(TuningUnavailable) as caught:
        tune(bad_colour_system(), "2d", demo_frames, 5)
    assert str(caught.value) == NEEDS_EXTRA == "objrec-tune needs the tune extra: pip install 'objrec[tune]'"


def test_optuna_is_imported_only_when_a_search_starts():
    import subprocess

    code = ("import sys, objrec_core.tuning, objrec_core.testing; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('optuna', 'cv2', 'open3d')), end=' '); "
            "import objrec_apps.tune; print('optuna' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True)
    assert out.stdout.strip() == "[] False"  # the framework's part needs neither Optuna nor OpenCV


def test_log_scale_spans_orders_of_magnitude():
    feature = {d.parameter: d for d in module_dimensions(FeatureDetector)}
    rng = random.Random(1)
    drawn = [feature["akaze_threshold"].sample(rng) for _ in range(400)]
    below = sum(v < 1e-3 for v in drawn) / len(drawn)  # two of the four decades lie below 1e-3
    assert 0.4 < below < 0.6
    assert all(1e-5 <= v <= 0.1 and math.isfinite(v) for v in drawn)


def test_the_feature_system_tunes_its_ratio_and_inlier_settings():
    """The feature demo's poster system with a ratio that drops nearly every match and an inlier count it never
    reaches (F1 0.05 on these frames): searching its ratio and inlier settings finds the poster again."""
    from pathlib import Path

    from objrec_core import build_system

    system = build_system(Path(__file__).resolve().parents[2] / "params" / "feature_demo.yaml")
    system.module("poster").set_parameters(ratio=0.3, min_inliers=150)
    kind = get_kind("2d")
    with open_source("demo:frames=20", "2d") as source:
        frames = [(frame, kind.frame_truth(frame)) for frame in source]
    names = ["poster.ratio_test", "poster.ratio", "poster.min_matches", "poster.min_inliers",
             "poster.reprojection_threshold", "poster.min_inlier_coverage"]
    result = tune(system, kind, frames, 20, seed=0, held_out=0.3, search=names)
    assert result.history[0].score < 0.2  # the start, tried first
    assert result.score >= 0.95, result.table()
    assert result.held_out_frames == 6
    assert set(result.changed) <= set(names)
