"""Declared parameters: validation, bounds, atomic sets, observers and thread-safe snapshots."""

from __future__ import annotations

import threading

import pytest

from objrec2d import BinaryDetector, HSVFilter, MorphologyFilter
from objrec_core import Bool, Choice, Filter, Float, Int, Ordered, ParameterError, Str


class Knobs(Filter):
    kind = "2d"
    count = Int(3, "a count", min=1, max=9, step=2)
    gain = Float(0.5, "a gain", min=0.0, max=1.0, step=0.1)
    enabled = Bool(True, "on or off")
    mode = Choice("fast", ["fast", "exact"], "how")
    note = Str("x", "free text")

    def filter(self, frame):
        return frame


def test_out_of_range_names_module_parameter_value_and_range():
    hsv = HSVFilter()
    with pytest.raises(ValueError) as info:
        hsv.set_parameters(h_min=300)
    message = str(info.value)
    assert "HSVFilter" in message and "h_min" in message and "300" in message and "0..179" in message
    assert isinstance(info.value, ParameterError)
    assert (info.value.module, info.value.parameter, info.value.value) == ("HSVFilter", "h_min", 300)
    assert hsv.h_min == 0


@pytest.mark.parametrize(
    ("name", "value", "fragment"),
    [
        ("count", 4, "steps of 2"),
        ("count", 11, "1..9"),
        ("count", 2.0, "integer"),
        ("count", True, "integer"),
        ("gain", "0.5", "number"),
        ("gain", float("nan"), "finite"),
        ("gain", 1.5, "0..1"),
        ("enabled", "yes", "true or false"),
        ("mode", "slow", "one of fast, exact"),
        ("note", 3, "text"),
        ("nonexistent", 1, "no such parameter"),
    ],
)
def test_every_declared_type_refuses_bad_values(name, value, fragment):
    knobs = Knobs(id="k1")
    with pytest.raises(ParameterError) as info:
        knobs.set_parameters(**{name: value})
    assert fragment in str(info.value)
    assert "Knobs 'k1'" in str(info.value)


def test_values_are_canonical_and_specs_come_from_the_declaration():
    knobs = Knobs(gain=1)
    assert knobs.gain == 1.0 and isinstance(knobs.gain, float)
    specs = {s.name: s for s in Knobs.parameter_specs()}
    assert list(specs) == ["count", "gain", "enabled", "mode", "note"]
    assert (specs["count"].min, specs["count"].max, specs["count"].step) == (1, 9, 2)
    assert specs["mode"].choices == ("fast", "exact")
    assert specs["gain"].doc == "a gain"
    assert knobs.get_parameters() == {"count": 3, "gain": 1.0, "enabled": True, "mode": "fast", "note": "x"}


def test_a_set_is_all_or_nothing():
    hsv = HSVFilter(h_min=10)
    with pytest.raises(ParameterError):
        hsv.set_parameters(h_min=20, h_max=999)
    assert hsv.get_parameters()["h_min"] == 10 and hsv.h_max == 179


def test_observers_hear_each_change_once_with_what_changed_and_not_a_non_change():
    hsv = HSVFilter()
    heard = []
    hsv.watch(lambda changes: heard.append([(c.subject, c.name, c.old, c.new) for c in changes]))
    hsv.set_parameters(h_min=5, h_max=50)
    hsv.h_min = 7
    hsv.set_parameters(h_min=7)
    assert heard == [[(hsv, "h_min", 0, 5), (hsv, "h_max", 179, 50)], [(hsv, "h_min", 5, 7)]]


def test_a_watch_on_names_hears_only_those():
    hsv = HSVFilter()
    heard = []
    hsv.watch(lambda changes: heard.extend((c.name, c.new) for c in changes), names={"v_min"})
    hsv.set_parameters(h_min=5, v_min=9)
    hsv.set_parameters(s_min=3)
    assert heard == [("v_min", 9)]


def test_a_failing_observer_does_not_stop_the_others(caplog):
    hsv = HSVFilter()
    heard = []

    def broken(_changes):
        raise RuntimeError("view is gone")

    hsv.watch(broken)
    hsv.watch(lambda changes: heard.append(changes[0].subject.h_min))
    hsv.h_min = 3
    assert heard == [3]
    assert "view is gone" in caplog.text


def test_snapshots_stay_consistent_while_another_thread_sets_values():
    hsv = HSVFilter(h_min=0, h_max=0)
    stop = threading.Event()
    torn = []

    def reader():
        while not stop.is_set():
            p = hsv.params
            if p.h_min != p.h_max:
                torn.append((p.h_min, p.h_max))

    thread = threading.Thread(target=reader)
    thread.start()
    for i in range(3000):
        hsv.set_parameters(h_min=i % 180, h_max=i % 180)
    stop.set()
    thread.join()
    assert torn == []


def test_ids_distinguish_two_modules_of_one_class():
    a, b = MorphologyFilter(id="open_small"), MorphologyFilter(id="close_big", operation="close")
    assert (a.id, b.id) == ("open_small", "close_big")
    assert BinaryDetector().id == "BinaryDetector"
    with pytest.raises(ValueError, match="module id"):
        MorphologyFilter(id="has space")


def test_a_parameter_may_not_hide_the_framework_s_own_attributes():
    with pytest.raises(TypeError, match="'id'"):

        class Clash(Filter):
            id = Int(0, "clashes with the module id")

            def filter(self, frame):
                return frame


def test_reset_restores_defaults():
    m = MorphologyFilter(operation="close", iterations=4, kernel_size=7)
    m.reset_parameters()
    assert m.get_parameters() == {"operation": "open", "iterations": 1, "kernel_size": 3, "kernel_shape": "rect"}


def test_the_snapshot_is_typed_immutable_and_refuses_a_typo():
    hsv = HSVFilter(h_min=10)
    p = hsv.params
    assert (p.h_min, p.h_max) == (10, 179)
    with pytest.raises(AttributeError):
        _ = p.h_mim
    with pytest.raises(AttributeError):
        p.h_min = 3  # frozen: a worker's snapshot never changes under it
    hsv.h_min = 20
    assert p.h_min == 10 and hsv.params.h_min == 20


class Ranged(Filter):
    kind = "2d"
    low = Float(0.1, "lower", min=0.0, max=None, soft_max=5.0)
    high = Float(1.0, "upper", min=0.0, max=None, soft_max=5.0)
    count = Int(300, "open below and above", min=None, max=None)
    order = Ordered("low", "high")

    def filter(self, frame):
        return frame


def test_open_bounds_soft_bounds_and_a_declared_rule():
    r = Ranged()
    assert r.parameter_spec("low").slider_range == (0.0, 5.0)
    assert r.parameter_spec("count").slider_range is None
    r.set_parameters(high=50.0)  # past the slider's range, inside the (open) hard bounds
    r.set_parameters(count=-10**12)
    assert (r.high, r.count) == (50.0, -10**12)
    with pytest.raises(ParameterError) as info:
        r.set_parameters(low=60.0)
    assert "low=60.0" in str(info.value) and "high=50.0" in str(info.value)
    assert r.low == 0.1  # refused whole
    with pytest.raises(ValueError, match="soft bound"):
        Float(1.0, min=0.0, max=1.0, soft_max=2.0)


class Picky(Filter):
    kind = "2d"
    method = Choice("plain", ["plain", "fancy", "exotic"], "how",
                    unavailable=lambda: {"exotic": "needs the exotic library"})
    fancy_level = Int(1, "only for fancy", min=1, max=3, relevant={"method": ("fancy",)})

    def filter(self, frame):
        return frame


def test_relevance_and_unavailable_choices_are_declared():
    picky = Picky()
    spec = picky.parameter_spec("method")
    assert spec.available_choices == ("plain", "fancy")
    with pytest.raises(ParameterError, match="not available here: needs the exotic library"):
        picky.method = "exotic"
    assert picky.relevant_parameters() == ["method"]
    picky.method = "fancy"
    assert picky.relevant_parameters() == ["method", "fancy_level"]
    assert "only when method is fancy" in picky.parameter_spec("fancy_level").relevance_text()
