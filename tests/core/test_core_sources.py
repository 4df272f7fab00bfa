"""One spec grammar for every kind's sources, source types found by entry point, and errors that list what
is accepted."""

from __future__ import annotations

import pytest

from objrec_core import (
    Frame,
    FrameSource,
    Int,
    SourceError,
    SourceSpec,
    Str,
    get_kind,
    kind_names,
    open_source,
    register_source,
    source_kinds,
    source_types,
)
from objrec_core.registry import unregister_source


def test_spec_grammar_scheme_options_positional_and_paths():
    schemes = {"demo", "camera", "rgbd"}
    spec = SourceSpec.parse("demo:seed=3,frames=100", schemes)
    assert (spec.scheme, dict(spec.options), spec.positional, spec.path) == (
        "demo", {"seed": "3", "frames": "100"}, (), None)
    assert SourceSpec.parse("camera:0", schemes).positional == ("0",)
    assert SourceSpec.parse("demo", schemes).scheme == "demo"
    assert SourceSpec.parse("rgbd:a.png,b.png,frames=2", schemes).positional == ("a.png", "b.png")
    assert SourceSpec.parse("c:/data/x.png", schemes).path is not None  # an unknown scheme is a path
    assert SourceSpec.parse("clip:01.png", schemes).path is not None
    with pytest.raises(SourceError, match="given twice"):
        SourceSpec.parse("demo:seed=1,seed=2", schemes)
    with pytest.raises(SourceError, match="go first"):
        SourceSpec.parse("demo:seed=1,4", schemes)
    with pytest.raises(SourceError, match="no source given"):
        SourceSpec.parse("  ", schemes)


@pytest.mark.parametrize("kind", ["2d", "3d"])
def test_the_demo_takes_the_same_options_in_every_built_in_kind(kind):
    source = open_source("demo:seed=3,frames=4", kind)
    frames = list(source)
    assert len(frames) == 4 and source.length == 4 and source.rate == 30.0
    assert all(get_kind(kind).is_frame(f.data) for f in frames)
    assert [f.index for f in frames] == [0, 1, 2, 3]
    assert open_source("demo", kind).length is None  # endless unless frames= is given
    again = next(iter(open_source("demo:3", kind)))  # a value without a key is the first positional option
    assert get_kind(kind).frames_equal(again.data, frames[0].data)


@pytest.mark.parametrize(
    ("spec", "kind", "message"),
    [
        ("demo:seed=-1", "2d", "demo:seed=-1: option seed='-1' is invalid: out of range, allowed int in 0..2147483647"),
        ("demo:frames=many", "3d", "option frames='many' is invalid: expected int"),
        ("demo:speed=2", "2d", "unknown option 'speed' (options: seed, frames, truth)"),
        ("demo:1,2", "2d", "too many values without a key"),
        ("ftp:x", "2d",
         "no such file or folder (2d sources: schemes bag:, camera:, demo:, ros1:, ros2:; files .avi .bag"),
        ("nothing/here.png", "2d", "no such file or folder"),
        ("demo", None, "a source of several kinds (2d, 3d)"),
        ("demo", "4d", "unknown data kind '4d'"),
    ],
)
def test_bad_specs_say_what_is_wrong_and_what_is_accepted(spec, kind, message):
    with pytest.raises((SourceError, LookupError)) as info:
        open_source(spec, kind)
    assert message in str(info.value)


def test_a_file_of_another_kind_is_named_as_such(shared_data):
    with pytest.raises(SourceError, match="a source of 3d data, but this pipeline works on 2d data"):
        open_source(str(shared_data / "clouds" / "office1.pcd"), "2d")
    with pytest.raises(SourceError, match="a source of 2d data, but this pipeline works on 3d data"):
        open_source(str(shared_data / "images" / "box.png"), "3d")
    assert source_kinds(str(shared_data / "images" / "box.png")) == ["2d"]
    assert open_source(str(shared_data / "clouds" / "office1.pcd")).length == 1  # one kind reads it


def test_built_in_kinds_and_sources_come_from_entry_points():
    assert {"2d", "3d"} <= set(kind_names())
    names = {(t.kind, t.__name__) for t in source_types()}
    assert {("2d", "DemoSource"), ("2d", "CameraSource"), ("2d", "VideoSource"), ("3d", "FileSource"),
            ("3d", "RGBDSource")} <= names
    assert all(t.kind == "3d" for t in source_types("3d"))


class CountdownSource(FrameSource):
    """A source type added in code the way a plug-in adds one by entry point."""

    kind = "2d"
    schemes = ("countdown",)
    extensions = (".count",)
    options = {"start": Int(3, "first number", min=1, max=100), "label": Str("n", "a name")}  # noqa: RUF012
    positional = ("start",)

    @classmethod
    def from_spec(cls, spec, options):
        source = cls()
        source.name, source.start = spec.text, options["start"]
        return source

    @property
    def length(self):
        return self.start

    def __iter__(self):
        import numpy as np

        for i in range(self.start, 0, -1):
            yield Frame(np.full((4, 4), i, np.uint8), index=self.start - i, source=self.name)


def test_a_new_source_type_plugs_in_with_its_own_scheme_and_extension(tmp_path):
    register_source(CountdownSource, "2d.countdown")
    try:
        source = open_source("countdown:5", "2d")
        assert [int(f.data[0, 0]) for f in source] == [5, 4, 3, 2, 1]
        (tmp_path / "x.count").write_text("")
        assert open_source(str(tmp_path / "x.count"), "2d").length == 3
        with pytest.raises(SourceError, match=r"countdown:start=0: option start='0' is invalid: out of range"):
            open_source("countdown:start=0", "2d")
        with pytest.raises(SourceError, match="a source of 2d data"):
            open_source("countdown:2", "3d")
    finally:
        unregister_source("2d.countdown")
    with pytest.raises(SourceError, match="no such file or folder"):
        open_source("countdown:5", "2d")
