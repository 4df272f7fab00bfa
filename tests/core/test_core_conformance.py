"""Every registered module keeps what its declarations promise (objrec_core.testing.check_module), each check
its own pytest case, with the defaults a plug-in author runs (the full-size demo frames, ``seconds`` of CPU
per frame); and the checker catches modules that do not: each broken module below differs from a correct one
by one bug."""

from __future__ import annotations

import time

import numpy as np
import pytest

from objrec2d import ImageDetector, ImageFilter
from objrec2d.messages import DetectedObject2D, Polygon
from objrec_core import Int, ParameterError, Rect, module_type, module_type_names
from objrec_core.testing import MODULE_CHECK_IDS, cases, check_module, run_case

#: Cases that take more than a few seconds: ShapeDetector's ~35 boundary values, each a RANSAC search of a
#: full 640 x 480 demo cloud (about a second of CPU each, three at most at max_objects=50 or normal_window=50).
SLOW = {("ShapeDetector", "boundaries")}
MODULE_CASES = [pytest.param(name, check, id=f"{name}::{check}",
                             marks=[pytest.mark.slow] if (name, check) in SLOW else [])
                for name in module_type_names() for check in MODULE_CHECK_IDS]


@pytest.mark.parametrize(("name", "check"), MODULE_CASES)
def test_registered_module_conforms(name, check):
    klass = module_type(name)
    if klass.kind == "3d":
        pytest.importorskip("open3d")
    (case,) = [c for c in cases(klass) if c.id == f"{name}::{check}"]
    run_case(case)


def test_a_whole_check_reports_what_it_did():
    from objrec2d import MorphologyFilter

    report = check_module(MorphologyFilter)
    assert report.checks == ["declarations", "refusals", "frames at the defaults", "boundary values",
                             "change events", "repr", "parameter file round trip", "snapshots across threads",
                             "search space"]
    assert report.refused >= 3 * len(MorphologyFilter.parameter_specs())  # every parameter has several bad values
    assert report.boundaries >= len(MorphologyFilter.parameter_specs())
    assert report.frames >= 3
    assert report.snapshots >= 1000
    assert 0 < report.frame_cpu_seconds < 10.0  # measured, and within the default limit


# -- broken modules: each is a correct one with one bug ---------------------------------------------------
class GoodFilter(ImageFilter):
    """Brightens the image by ``gain`` levels; the correct base of the broken filters below."""

    gain = Int(10, "levels added", min=0, max=100)
    low = Int(20, "a lower level", min=0, max=255)
    high = Int(200, "an upper level", min=0, max=255)
    mode = Int(1, "an odd mode", min=1, max=9, step=2)

    def filter(self, frame):
        p = self.params
        return np.clip(frame.astype(np.int16) + p.gain, 0, 255).astype(np.uint8)


class LaxInt(Int):
    """An Int that forgets its bounds."""

    def validate(self, value, module):
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        return super().validate(value, module)


class LaxDeclarationFilter(GoodFilter):
    gain = LaxInt(10, "levels added", min=0, max=100)


class LaxValidationFilter(GoodFilter):
    """Lets any integer ``high`` past its own validation."""

    def validate_parameters(self, values):
        lax = {k: v for k, v in values.items() if k == "high" and isinstance(v, int) and not isinstance(v, bool)}
        rest = {k: v for k, v in values.items() if k not in lax}
        return {**super().validate_parameters(rest), **lax}


class InPlaceFilter(GoodFilter):
    """Brightens the input itself instead of a copy."""

    def filter(self, frame):
        np.add(frame, np.uint8(1), out=frame)
        return frame


class OneAtATimeFilter(GoodFilter):
    """Applies a value set one value at a time: a reader can see half of it."""

    def set_parameters(self, **values):
        for name, value in values.items():
            super().set_parameters(**{name: value})


class StaleReprFilter(GoodFilter):
    """Shows the values it was made with, whatever they are now."""

    def __init__(self, id=None, **parameters):
        super().__init__(id, **parameters)
        self._shown = ", ".join(f"{k}={v!r}" for k, v in self.get_parameters().items())

    def __repr__(self):
        return f"{type(self).__name__}(id={self.id!r}, {self._shown})"


class GoodDetector(ImageDetector):
    """Reports the selected rectangle as an object; keeps the selection as state in parameter files."""

    margin = Int(0, "pixels added around the selection", min=0, max=50)

    def __init__(self, id=None, **kwargs):
        self._rect = None
        super().__init__(id, **kwargs)

    def process_area_selection(self, rect, frame):
        self._rect = rect

    def detect(self, frame):
        if self._rect is None:
            return []
        r, m = self._rect, self.params.margin
        corners = [(r.x - m, r.y - m), (r.x + r.width + m, r.y - m), (r.x + r.width + m, r.y + r.height + m)]
        return [DetectedObject2D(self.object_name, Polygon.from_xy(corners))]

    def get_state(self):
        if self._rect is None:
            return None
        r = self._rect
        return {"rect": [r.x, r.y, r.width, r.height]}

    def prepare_state(self, state, parameters):
        if state is None:
            return None
        return Rect(*state["rect"])

    def apply_state(self, prepared):
        self._rect = prepared


class ForgetfulDetector(GoodDetector):
    """Drops the saved selection's size when it loads a file."""

    def prepare_state(self, state, parameters):
        if state is None:
            return None
        x, y, _, _ = state["rect"]
        return Rect(x, y, 1, 1)


class DrawingDetector(GoodDetector):
    """Draws its finding into the frame it was given."""

    def detect(self, frame):
        found = super().detect(frame)
        frame[:2, :2] = 255 - frame[:2, :2]
        return found


def test_the_correct_modules_pass():
    for klass in (GoodFilter, GoodDetector):
        report = check_module(klass)
        assert report.refused > 0 and report.frames > 0 and report.snapshots > 0


@pytest.mark.parametrize(
    ("klass", "expected"),
    [
        (LaxDeclarationFilter, r"\[refusals\] gain=-1: one below the hard minimum was accepted"),
        (LaxValidationFilter, r"\[refusals\] high=-1: one below the hard minimum was accepted"),
        (InPlaceFilter, r"\[frames at the defaults\]: modified its input frame in place"),
        (DrawingDetector, r"\[frames at the defaults\]: modified its input frame in place"),
        (ForgetfulDetector, r"\[parameter file round trip\]: the state did not survive the file"),
        (OneAtATimeFilter, r"\[snapshots across threads\]: a snapshot .* mixes the two value sets"),
        (StaleReprFilter, r"\[repr\] gain=11: repr\(module\) does not show gain=11"),
    ],
    ids=lambda v: v.__name__ if isinstance(v, type) else "",
)
def test_broken_module_is_caught(klass, expected):
    with pytest.raises(AssertionError, match=expected) as info:
        check_module(klass)
    assert str(info.value).startswith(f"{klass.__name__} [")


def test_refusal_message_must_name_the_value():
    class MuteFilter(GoodFilter):
        def validate_parameters(self, values):
            try:
                return super().validate_parameters(values)
            except ParameterError as exc:
                if exc.parameter != "gain":
                    raise
                raise ParameterError(self.label, exc.parameter, "?", "not allowed") from None

    with pytest.raises(AssertionError, match=r"MuteFilter \[refusals\] gain=-1: .* does not show the value"):
        check_module(MuteFilter)


def spin(cpu_seconds: float) -> None:
    """Use the CPU for ``cpu_seconds`` of this thread's CPU time."""
    end = time.thread_time() + cpu_seconds
    while time.thread_time() < end:
        pass


def test_a_frame_over_its_cpu_time_fails_without_being_waited_for():
    """At gain=100 a frame spins for 2 s of CPU; the check stops waiting at 0.2 s of it."""
    slow_frames = []

    class SlowFilter(GoodFilter):
        def filter(self, frame):
            if self.params.gain == 100:
                slow_frames.append(frame)
                spin(2.0)
            return super().filter(frame)

    with pytest.raises(AssertionError, match=r"\[boundary values\] gain=100: one frame took more than 0.2 s of CPU "
                                             r"time \(still running\)"):
        check_module(SlowFilter, seconds=0.2)
    assert len(slow_frames) == 1  # the check stopped at the first frame over its allowance


def test_waiting_is_not_cpu_time():
    """A frame that waits (for a device, or on a busy machine) uses no CPU: it is not slow."""

    class WaitingFilter(GoodFilter):
        def filter(self, frame):
            time.sleep(0.3 if self.params.gain == 100 else 0.0)
            return super().filter(frame)

    report = check_module(WaitingFilter, seconds=0.2)
    assert report.frame_cpu_seconds < 0.2


def test_a_module_declares_a_deviation_with_its_reason():
    class ShowsOldValues(StaleReprFilter):
        expected_failures = {"repr": "the repr is fixed at construction (a known limitation)"}  # noqa: RUF012

    report = check_module(ShowsOldValues)
    assert list(report.deviations.failed_as_declared) == ["ShowsOldValues::repr"]
    assert report.deviations.failed_as_declared["ShowsOldValues::repr"].startswith(
        "the repr is fixed at construction (a known limitation) (failed as declared: ShowsOldValues [repr] gain=11")
    assert "parameter file round trip" in report.checks  # the checks after it still ran
    outcomes = {case.id: case() for case in cases(ShowsOldValues)}
    assert outcomes["ShowsOldValues::repr"] == "deviated"
    assert {outcome for case_id, outcome in outcomes.items() if case_id != "ShowsOldValues::repr"} == {"passed"}

