"""Parameter types carry their own meaning: text parsing, invalid examples, boundary values, alternatives and
description live on the declaration classes, so a plug-in adds a type (tests/param_plugin's ``Colour``) that
source options and the conformance suite use with no framework edit. Also: optional values (None), open
intervals, deprecated sentinels, and a subclass's ``h_min = 10`` changing the inherited default."""

from __future__ import annotations

import logging
import math
import sys
from pathlib import Path

import pytest
import yaml

from objrec2d import BinaryDetector, HSVFilter, MorphologyFilter
from objrec_core import (
    Bool,
    Choice,
    Float,
    FrameSource,
    Int,
    ParameterError,
    ParameterStorage,
    RecognitionSystem,
    SourceError,
    SourceSpec,
    Str,
    open_source,
    register_module,
)
from objrec_core.registry import unregister_module
from objrec_core.testing import check_module

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "param_plugin"))
from objrec_colour import Colour, TintFilter

FRAMEWORK = ("declare", "objrec_core", "objrec2d", "objrec_apps")


def bound(spec, name="p", owner="Owner"):
    """A declaration named as a class body would name it."""
    return spec.bind(name, owner)


# -- the plug-in's type ---------------------------------------------------------------------------------
def test_no_framework_module_knows_the_plugin_type():
    root = Path(__file__).resolve().parents[2]
    for package in FRAMEWORK:
        for path in (root / package).rglob("*.py"):
            assert "objrec_colour" not in path.read_text(), path


def test_plugin_type_passes_the_conformance_suite_with_its_own_values():
    report = check_module(TintFilter)
    assert report.checks == ["declarations", "refusals", "frames at the defaults", "boundary values",
                             "change events", "repr", "parameter file round trip", "snapshots across threads",
                             "search space"]
    colour = TintFilter.parameter_spec("tint")
    strength = TintFilter.parameter_spec("strength")
    ceiling = TintFilter.parameter_spec("ceiling")
    expected_refusals = sum(len(s.invalid_examples()) for s in (colour, strength, ceiling))
    assert expected_refusals == 7 + 8 + 9  # tint: 6 + None; strength: 0 itself, no None; ceiling: None allowed
    assert report.refused == expected_refusals + 1  # and an undeclared parameter
    # boundaries: black, white; just above 0 and 1; 1, 255 and None (the defaults are not counted twice)
    assert report.boundaries >= 6


def test_plugin_type_reads_text_its_own_way():
    colour = bound(Colour("#ff8000", "a colour"), "tint")
    assert colour.parse_text("red") == "#ff0000"
    assert colour.parse_text(" FF8000 ") == "#ff8000"
    assert colour.parse_text("#00Ff00") == "#00ff00"
    with pytest.raises(ParameterError) as info:
        colour.parse_text("#12345", "Paint")
    assert str(info.value) == "Paint: parameter tint='#12345' is invalid: expected a colour #rrggbb in lower case " \
                              "(e.g. #ff8000)"
    with pytest.raises(ParameterError, match="tint=None"):
        colour.validate(None, "Paint")  # not optional


def test_plugin_type_refuses_every_invalid_example_and_accepts_its_boundaries():
    colour = bound(Colour("#ff8000", "a colour"), "tint")
    for why, value in colour.invalid_examples():
        with pytest.raises(ParameterError):
            colour.validate(value, "Paint")
        assert why
    assert [colour.validate(v, "Paint") for v in colour.boundary_values()] == ["#000000", "#ffffff"]
    assert colour.alternatives("#000000") == ["#808080", "#ffffff"]
    assert colour.describe() == "colour #rrggbb"


class PaintSource(FrameSource):
    """A source whose option is of the plug-in's type: ``paint:red``."""

    kind = "2d"
    schemes = ("paint",)
    options = {"tint": Colour("#000000", "the colour of every frame")}  # noqa: RUF012 - a declaration
    positional = ("tint",)

    def __iter__(self):
        return iter(())


@pytest.mark.parametrize(("text", "tint"), [("paint", "#000000"), ("paint:red", "#ff0000"),
                                            ("paint:tint=00FF00", "#00ff00")])
def test_plugin_type_is_a_source_option(text, tint):
    assert PaintSource.typed_options(SourceSpec.parse(text, {"paint"})) == {"tint": tint}


def test_a_source_option_the_plugin_type_refuses_is_one_line_naming_option_and_text():
    with pytest.raises(SourceError) as info:
        PaintSource.typed_options(SourceSpec.parse("paint:tint=mauve", {"paint"}))
    assert str(info.value) == "paint:tint=mauve: option tint='mauve' is invalid: expected a colour #rrggbb in " \
                              "lower case (e.g. #ff8000)"


def test_plugin_type_keeps_optional_and_open_values_through_a_parameter_file(tmp_path):
    register_module(TintFilter)
    try:
        system = RecognitionSystem([TintFilter(id="warm", tint="#ffa000", strength=0.25), BinaryDetector()])
        path = tmp_path / "warm.yaml"
        ParameterStorage(system).save_parameters(path)
        saved = yaml.safe_load(path.read_text())["pipeline"][0]["parameters"]
        assert saved == {"tint": "#ffa000", "strength": 0.25, "ceiling": None}
        assert "ceiling: null" in path.read_text()
        system.modules[0].set_parameters(tint="#000000", ceiling=200)
        ParameterStorage(system).load_parameters(path)
        assert system.modules[0].get_parameters() == saved
    finally:
        unregister_module("TintFilter")


# -- parse_text of the built-in types -------------------------------------------------------------------
@pytest.mark.parametrize(("spec", "text", "value"), [
    (Int(0, min=0), "42", 42),
    (Int(0), " -7 ", -7),
    (Float(0.0), "0.25", 0.25),
    (Float(0.0), "1e3", 1000.0),
    (Bool(False), "yes", True),
    (Bool(False), "On", True),
    (Bool(True), "0", False),
    (Bool(True), "FALSE", False),
    (Str(""), "hello", "hello"),
    (Choice("fast", ["fast", "exact"]), "exact", "exact"),
    (Int(None, min=1, optional=True), "none", None),
    (Float(None, optional=True), "NULL", None),
    (Choice(None, ["a", "b"], optional=True), "none", None),
])
def test_parse_text_gives_the_valid_value(spec, text, value):
    parsed = bound(spec).parse_text(text, "Owner")
    assert parsed == value and type(parsed) is type(value)


@pytest.mark.parametrize(("spec", "text", "rule"), [
    (Int(0), "4.5", "expected int in -inf..inf"),
    (Int(0, min=0, max=9), "12", "out of range, allowed int in 0..9"),
    (Int(1, min=1, max=9, step=2), "4", "not allowed, int in 1..9 in steps of 2 from 1"),
    (Float(0.0), "nan", "expected a finite number"),
    (Float(0.5, min=0.0, min_open=True, max=1.0), "0", "out of range, allowed float in (0..1]"),
    (Bool(False), "maybe", "expected bool"),
    (Choice("fast", ["fast", "exact"]), "slow", "one of fast, exact"),
    (Int(0), "none", "expected int in -inf..inf"),  # none is a value only for an optional parameter
])
def test_parse_text_refuses_in_one_line_naming_module_parameter_and_text(spec, text, rule):
    with pytest.raises(ParameterError) as info:
        bound(spec, "level").parse_text(text, "Source")
    message = str(info.value)  # the value as read where there is one (12), else the text ('4.5')
    assert message.startswith("Source: parameter level=") and message.endswith(f" is invalid: {rule}")
    assert text.strip() in message and "\n" not in message


@pytest.mark.parametrize(("spec", "texts"), [
    (Int(3, min=1, max=9, step=2), ["0", "10", "2", "many", "", "1.5"]),
    (Int(None, min=1, optional=True, deprecated={0: None}), ["-1", "many", "", "1.5"]),  # 0 is read, as deprecated
    (Float(0.5, min=0.0, min_open=True, max=1.0), ["0.0", "1.0000000000000002", "nan", "inf", "-inf", "many", ""]),
    (Bool(True), ["maybe", "2", ""]),
    (Choice("a", ["a", "b"], unavailable=lambda: {"b": "no"}), ["no-such-choice", "A", "b"]),
    (Str("x"), []),  # any text is text
    (Colour("#ff8000"), ["mauve", "#12345", "gg0000"]),
])
def test_every_invalid_text_is_refused_by_parse_text(spec, texts):
    spec = bound(spec)
    assert [text for _, text in spec.invalid_texts()] == texts
    for why, text in spec.invalid_texts():
        with pytest.raises(ParameterError):
            spec.parse_text(text, "Source")
        assert why


def test_a_type_without_text_says_so():
    class Anything(Int):
        def from_text(self, text):
            raise NotImplementedError

    with pytest.raises(ParameterError, match="int values cannot be given as text"):
        bound(Anything(0)).parse_text("3")


# -- invalid_examples -----------------------------------------------------------------------------------
@pytest.mark.parametrize("spec", [
    Int(3, min=1, max=9, step=2), Int(7), Int(None, min=1, optional=True, deprecated={0: None}),
    Int(5, min=0, min_open=True, max=10, max_open=True),
    Float(0.5, min=0.0, max=1.0), Float(0.5, min=0.0, min_open=True, max=1.0), Float(2.0),
    Bool(True), Str("x"), Choice("fast", ["fast", "exact"]),
    Choice("a", ["a", "b", "c"], unavailable=lambda: {"b": "no"}),
])
def test_every_invalid_example_is_refused(spec):
    spec = bound(spec)
    examples = spec.invalid_examples()
    assert len(examples) >= 3
    for why, value in examples:
        with pytest.raises(ParameterError):
            spec.validate(value, "Owner")
        assert why


def test_int_invalid_examples_name_each_bound_and_the_step():
    examples = dict(bound(Int(3, min=1, max=9, step=2)).invalid_examples())
    assert examples["one below the hard minimum"] == 0 and examples["one above the hard maximum"] == 10
    assert examples["off the step of 2"] == 2 and examples["a whole float"] == 3.0
    assert examples["None"] is None


def test_open_bounds_give_the_excluded_bound_itself():
    assert dict(bound(Int(5, min=0, min_open=True, max=10, max_open=True)).invalid_examples())[
        "the excluded minimum"] == 0
    examples = dict(bound(Float(0.5, min=0.0, min_open=True, max=1.0, max_open=True)).invalid_examples())
    assert examples["the excluded minimum"] == 0.0 and examples["the excluded maximum"] == 1.0


def test_optional_and_deprecated_values_are_not_invalid_examples():
    examples = [v for _, v in bound(Int(None, min=1, optional=True, deprecated={0: None})).invalid_examples()]
    assert None not in examples and 0 not in examples
    assert 1.0 in examples and True in examples


def test_choice_invalid_examples_hold_unknown_wrong_case_and_unavailable():
    examples = dict(bound(Choice("a", ["a", "b"], unavailable=lambda: {"b": "not built"})).invalid_examples())
    assert examples["an unknown choice"] == "no-such-choice" and examples["a choice in the wrong case"] == "A"
    assert examples["an unavailable choice (not built)"] == "b"


# -- boundary_values ------------------------------------------------------------------------------------
@pytest.mark.parametrize(("spec", "values"), [
    (Int(3, min=1, max=9, step=2), [1, 9]),
    (Int(4, min=0, max=9, step=2), [0, 8]),
    (Int(50, min=0, max=1000, soft_max=100), [0, 1000, 100]),
    (Int(5, min=0, min_open=True, max=10, max_open=True), [1, 9]),
    (Int(7), []),
    (Float(0.5, min=0.0, max=1.0, soft_min=0.25), [0.0, 1.0, 0.25]),
    (Float(0.5, min=0.0, min_open=True, max=1.0), [5e-324, 1.0]),
    (Float(0.5, min=0.0, max=1.0, max_open=True), [0.0, math.nextafter(1.0, 0.0)]),
    (Int(None, min=1, max=5, optional=True), [1, 5, None]),
    (Bool(True), [False, True]),
    (Str("x"), ["", "x"]),
    (Choice("a", ["a", "b", "c"], unavailable=lambda: {"b": "no"}), ["a", "c"]),
])
def test_boundary_values_are_the_valid_extremes(spec, values):
    spec = bound(spec)
    assert spec.boundary_values() == values
    assert [spec.validate(v, "Owner") for v in values] == values


# -- alternatives ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(("spec", "default", "first"), [
    (Int(3, min=1, max=9, step=2), 3, 5),  # one step towards the middle
    (Int(9, min=1, max=9, step=2), 9, 7),
    (Float(0.0, min=0.0, max=1.0), 0.0, 0.5 / 7),  # a fraction, so a file must keep every digit
    (Int(None, min=1, optional=True), None, 1),  # from None, the first valid value
    (Bool(True), True, False),
    (Choice("a", ["a", "b"]), "a", "b"),
    (Str("x"), "x", "x-other"),
    (Str(""), "", "other"),
])
def test_alternatives_start_near_the_default(spec, default, first):
    spec = bound(spec)
    alternatives = spec.alternatives(default)
    assert alternatives[0] == pytest.approx(first) and type(alternatives[0]) is type(first)
    for value in alternatives:
        assert spec.validate(value, "Owner") == value or value is None
        assert value != default or type(value) is not type(default)


def test_an_optional_parameter_offers_none_last():
    assert bound(Int(3, min=1, max=9, optional=True)).alternatives(3)[-1] is None
    assert None not in bound(Int(3, min=1, max=9)).alternatives(3)


def test_alternatives_skip_an_excluded_bound():
    spec = bound(Float(0.5, min=0.0, min_open=True, max=1.0, max_open=True))
    assert 0.0 not in spec.alternatives(0.5) and 1.0 not in spec.alternatives(0.5)


# -- describe -------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("spec", "text"), [
    (Int(0, min=0, max=179), "int in 0..179"),
    (Int(1, min=1, max=9, step=2), "int in 1..9 in steps of 2 from 1"),
    (Float(0.5, min=0.0, min_open=True, max=1.0), "float in (0..1]"),
    (Float(0.5, min=0.0, max=1.0, max_open=True), "float in [0..1)"),
    (Float(1.0, min=0.0, min_open=True), "float in (0..inf)"),
    (Int(None, min=1, optional=True), "int in 1..inf, or none"),
    (Bool(True), "bool"),
    (Choice("a", ["a", "b"]), "one of a, b"),
])
def test_describe_says_the_allowed_values(spec, text):
    assert bound(spec).describe() == text


# -- open intervals -------------------------------------------------------------------------------------
def test_an_open_float_bound_refuses_the_bound_and_accepts_just_inside():
    spec = bound(Float(0.5, min=0.0, min_open=True, max=1.0), "strength")
    with pytest.raises(ParameterError, match=r"strength=0\.0 is invalid: out of range, allowed float in \(0\.\.1\]"):
        spec.validate(0.0, "Tint")
    assert spec.validate(1e-300, "Tint") == 1e-300 and spec.validate(1.0, "Tint") == 1.0


def test_an_open_int_bound_refuses_the_bound():
    spec = bound(Int(5, min=0, min_open=True, max=10, max_open=True))
    assert spec.validate(1, "X") == 1 and spec.validate(9, "X") == 9
    for value in (0, 10):
        with pytest.raises(ParameterError, match=r"allowed int in \(0\.\.10\)"):
            spec.validate(value, "X")


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"min": 1.0, "max": 1.0, "min_open": True}, "holds no value"),
    ({"max": 1.0, "min_open": True}, "an open bound needs its value"),
])
def test_an_impossible_interval_is_refused_at_declaration(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Float(1.0, **kwargs)


def test_a_default_on_an_excluded_bound_is_refused_at_declaration():
    with pytest.raises(ParameterError, match=r"Strong: parameter gain=0\.0 is invalid"):
        bound(Float(0.0, min=0.0, min_open=True), "gain", "Strong")


# -- optional values and deprecated sentinels -----------------------------------------------------------
def test_an_optional_parameter_takes_none_and_a_plain_one_refuses_it():
    assert bound(Int(None, min=1, optional=True)).validate(None, "X") is None
    with pytest.raises(ParameterError, match="p=None"):
        bound(Int(3, min=1)).validate(None, "X")


def test_a_deprecated_sentinel_is_read_logged_and_replaced(caplog):
    spec = bound(Int(None, min=1, optional=True, deprecated={0: None}), "frames")
    with caplog.at_level(logging.WARNING, logger="declare.parameters"):
        assert spec.validate(0, "demo") is None
        assert spec.parse_text("0", "demo") is None
    assert [r.getMessage() for r in caplog.records] == ["demo: frames=0 is deprecated; write none"] * 2
    assert spec.validate(3, "demo") == 3
    for not_the_sentinel in (False, 0.0):  # only the int 0 stands for none
        with pytest.raises(ParameterError):
            spec.validate(not_the_sentinel, "demo")


@pytest.mark.parametrize(("text", "length"), [("demo", None), ("demo:frames=none", None), ("demo:frames=0", None),
                                              ("demo:frames=4", 4)])
def test_the_demo_source_frames_option_is_optional_and_reads_the_old_zero(text, length, caplog):
    with caplog.at_level(logging.WARNING), open_source(text, "2d") as source:
        assert source.length == length
    assert ("deprecated" in caplog.text) == text.endswith("=0")


def test_the_demo_source_refuses_negative_frames():
    with pytest.raises(SourceError, match=r"option frames='-1' is invalid: out of range, allowed int in 1\.\.inf, "
                                          "or none"):
        open_source("demo:frames=-1", "2d")


# -- overriding a default in a subclass -----------------------------------------------------------------
def test_a_subclass_value_changes_the_inherited_default():
    class MyHSV(HSVFilter):
        h_min = 10

    spec = MyHSV.parameter_spec("h_min")
    assert spec.default == 10 and (spec.min, spec.max) == (0, 179) and spec.doc == HSVFilter.h_min.doc
    assert MyHSV().h_min == 10 and MyHSV().params.h_min == 10
    assert HSVFilter().h_min == 0 and HSVFilter.parameter_spec("h_min").default == 0
    assert [s.name for s in MyHSV.parameter_specs()] == [s.name for s in HSVFilter.parameter_specs()]
    module = MyHSV(h_min=20)
    module.reset_parameters()
    assert module.h_min == 10


def test_a_grandchild_inherits_the_overridden_default():
    class Child(MorphologyFilter):
        kernel_size = 7

    class Grandchild(Child):
        operation = "close"

    assert Grandchild.default_values()["kernel_size"] == 7 and Grandchild().operation == "close"


def test_a_subclass_value_the_declaration_refuses_names_class_and_parameter():
    with pytest.raises(ParameterError) as info:
        class TooRed(HSVFilter):
            h_min = 300
    assert str(info.value) == "TooRed: parameter h_min=300 is invalid: out of range, allowed int in 0..179"


def test_a_subclass_choice_outside_the_choices_is_refused():
    with pytest.raises(ParameterError, match="Wrong: parameter operation='melt' is invalid"):
        class Wrong(MorphologyFilter):
            operation = "melt"


def test_a_method_cannot_hide_a_parameter():
    with pytest.raises(TypeError, match="Hiding: 'h_min' is a declared parameter"):
        class Hiding(HSVFilter):
            def h_min(self):
                return 1
