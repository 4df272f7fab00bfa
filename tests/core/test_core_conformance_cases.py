"""Every built-in source type and data kind keeps its contract (objrec_core.testing.check_source and
check_kind), each check its own pytest case; a plug-in source is checked the same way; a broken source or kind
is caught by the check it breaks; and a declared deviation is recorded with its reason, or reported when it
does not happen."""

from __future__ import annotations

import contextlib
import importlib.util
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import cv2
import numpy as np
import pytest

from objrec2d.kind import ImageKind
from objrec_core import Frame, FrameSource, Int, open_source, register_kind, register_source
from objrec_core.registry import unregister_kind, unregister_source
from objrec_core.testing import (
    KIND_CHECKS,
    SOURCE_CHECKS,
    cases,
    check_kind,
    check_source,
    run_case,
)

ROOT = Path(__file__).resolve().parents[2]
SIGNAL_PLUGIN = ROOT / "tests" / "signal_kind"


# -- small files of every built-in source type --------------------------------------------------------------
def demo_images(count: int) -> list[np.ndarray]:
    from objrec2d import DemoSource

    return [frame.data for frame in DemoSource(seed=1, frames=count)]


def write_image(folder: Path) -> str:
    path = folder / "one.png"
    cv2.imwrite(str(path), demo_images(1)[0])
    return str(path)


def write_folder(folder: Path) -> str:
    images = folder / "images"
    images.mkdir()
    for number, image in enumerate(demo_images(3)):
        cv2.imwrite(str(images / f"frame{number}.png"), image)
    return str(images)


def write_video(folder: Path) -> str:
    path = folder / "clip.avi"
    images = demo_images(4)
    height, width = images[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (width, height))
    for image in images:
        writer.write(image)
    writer.release()
    return str(path)


def small_cloud():
    from objrec3d import PointCloud

    rng = np.random.default_rng(4)
    points = rng.uniform(-1.0, 1.0, (12 * 16, 3)).astype(np.float32)
    points[:, 2] += 2.0
    return PointCloud(points, None, 16, 12)


def write_pcd(folder: Path) -> str:
    from objrec3d.pcd import write_pcd as write

    path = folder / "cloud.pcd"
    write(path, small_cloud())
    return str(path)


def write_ply(folder: Path) -> str:
    o3d = pytest.importorskip("open3d")
    path = folder / "cloud.ply"
    o3d.io.write_point_cloud(str(path), small_cloud().to_open3d())
    return str(path)


def write_bag(folder: Path) -> str:
    pytest.importorskip("rosbags")
    spec = importlib.util.spec_from_file_location("objrec_record_demo_bag", ROOT / "scripts" / "record_demo_bag.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    path = folder / "demo.bag"
    script.record(path, 3, ["2d", "3d"], 0)
    return str(path)


#: Source name -> (kind, how to make its spec in a folder).
SOURCES = {
    "demo-2d": ("2d", lambda folder: "demo:frames=3"),
    "demo-3d": ("3d", lambda folder: "demo:frames=2"),
    "image": ("2d", write_image),
    "folder": ("2d", write_folder),
    "video": ("2d", write_video),
    "pcd": ("3d", write_pcd),
    "ply": ("3d", write_ply),
    "bag-2d": ("2d", write_bag),
    "bag-3d": ("3d", write_bag),
}


@pytest.fixture(scope="module")
def source_specs(tmp_path_factory) -> dict[str, str]:
    """Each source's spec, its file made on first use."""
    made: dict[str, str] = {}

    class Specs(dict):
        def __missing__(self, name: str) -> str:
            kind, make = SOURCES[name]
            if kind == "3d":
                pytest.importorskip("open3d")
            maker_name = getattr(make, "__name__", name)
            if maker_name not in made:
                made[maker_name] = make(tmp_path_factory.mktemp(name))
            self[name] = made[maker_name]
            return self[name]

    return Specs()


@pytest.mark.parametrize(("name", "check"), [(name, check) for name in SOURCES for check in SOURCE_CHECKS],
                         ids=[f"{name}::{check}" for name in SOURCES for check in SOURCE_CHECKS])
def test_built_in_source_conforms(source_specs, name, check):
    kind = SOURCES[name][0]
    by_check = {case.id.rpartition("::")[2]: case for case in cases(source_specs[name], kind=kind, id=name)}
    run_case(by_check[check])


@pytest.mark.parametrize(("name", "check"), [(name, check) for name in ("2d", "3d") for check in KIND_CHECKS],
                         ids=[f"kind-{name}::{check}" for name in ("2d", "3d") for check in KIND_CHECKS])
def test_built_in_kind_conforms(name, check):
    from objrec_core import get_kind

    if name == "3d":
        pytest.importorskip("open3d")
    by_check = {case.id.rpartition("::")[2]: case for case in cases(get_kind(name))}
    run_case(by_check[check])


def invalid_texts(source_class: type) -> int:
    """How many refusals check_source must see: one per invalid text each declared option's type gives."""
    return sum(len(option.invalid_texts()) for option in source_class.options.values())


def test_a_whole_source_check_reports_what_it_did(source_specs):
    report = check_source(source_specs["folder"], kind="2d")
    assert report.checks == list(SOURCE_CHECKS)
    assert report.seeks == 3  # frames 0, 1 and 2 of three, each started at with frames_from
    assert report.frames >= 3 * 3
    demo = check_source("demo:frames=3", kind="2d")
    # seed: -1, 2147483648, many, nothing, 1.5; frames: -1 (its 0 is the deprecated 'endless'), many, nothing, 1.5
    with open_source("demo:frames=1", "2d") as opened:
        assert demo.refused == invalid_texts(type(opened)) == 9
    assert demo.seeks == 0  # the demo scene is not seekable, and says so


# -- a plug-in source ------------------------------------------------------------------------------------------
@contextlib.contextmanager
def signal_plugin() -> Iterator[ModuleType]:
    """The signal kind plug-in imported from tests/signal_kind and registered in code, then forgotten."""
    sys.path.insert(0, str(SIGNAL_PLUGIN))
    try:
        import objrec_signal

        register_kind(objrec_signal.SignalKind)
        register_source(objrec_signal.WaveSource)
        yield objrec_signal
    finally:
        unregister_kind("signal")
        if "objrec_signal" in sys.modules:
            unregister_source(sys.modules["objrec_signal"].WaveSource)
        sys.path.remove(str(SIGNAL_PLUGIN))
        for module in [n for n in sys.modules if n == "objrec_signal" or n.startswith("objrec_signal.")]:
            del sys.modules[module]


def test_a_plugin_source_is_checked_by_check_source(tmp_path):
    with signal_plugin() as plugin:
        finite = check_source(plugin.WaveSource, spec="wave:frames=4")
        assert finite.checks == list(SOURCE_CHECKS) and finite.frames >= 4 * 3
        # every invalid text each option's type declares (past each bound, not a number, empty, a fraction)
        assert finite.refused == invalid_texts(plugin.WaveSource) == 26
        endless = check_source(plugin.WaveSource)  # "wave": endless, its first frames read
        assert endless.checks == list(SOURCE_CHECKS)
        recorded = tmp_path / "three.sig"
        recorded.write_text("0 1 0\n# a comment\n0 2 0\n1, 0, 1\n")
        assert check_source(plugin.WaveSource, spec=str(recorded)).frames >= 3
        kind = check_kind(plugin.SignalKind())
        assert kind.checks == list(KIND_CHECKS)


# -- broken sources: each differs from a correct one by one bug ----------------------------------------------
class CountingSource(FrameSource):
    """``count:frames=N``: N grey frames, seekable; the correct base of the broken sources below."""

    kind = "2d"
    schemes = ("count",)
    options = {"frames": Int(4, "how many frames", min=1, max=50)}  # noqa: RUF012 - declarations

    @classmethod
    def from_spec(cls, spec, options):
        return cls(spec.text, options["frames"])

    def __init__(self, name: str = "count", frames: int = 4) -> None:
        self.name, self.frames, self.closed = name, frames, 0

    @property
    def length(self):
        return self.frames

    @property
    def rate(self):
        return 10.0

    @property
    def seekable(self):
        return True

    def frame(self, index: int) -> Frame:
        return Frame(np.full((6, 8, 3), index * 10, np.uint8), 100.0 + index / 10, index, self.name)

    def __iter__(self):
        return self.frames_from(0)

    def frames_from(self, index):
        for number in range(max(0, index), self.frames):
            yield self.frame(number)


class LongerThanItSays(CountingSource):
    @property
    def length(self):
        return self.frames + 1


class OffByOneSeek(CountingSource):
    """Numbers the frames right, but a seek lands one frame late."""

    def frames_from(self, index):
        for number in range(max(0, index), self.frames):
            late = self.frame(min(number + 1, self.frames - 1)) if index else self.frame(number)
            yield Frame(late.data, late.stamp, number, self.name)


class CloseOnce(CountingSource):
    def close(self):
        self.closed += 1
        if self.closed > 1:
            raise RuntimeError("already closed")


class StampsBackwards(CountingSource):
    def frame(self, index):
        return Frame(np.full((6, 8, 3), index, np.uint8), 100.0 - index, index, self.name)


@contextlib.contextmanager
def registered(source_class):
    register_source(source_class, f"2d.{source_class.__name__}")
    try:
        yield
    finally:
        unregister_source(source_class)


def test_the_correct_source_passes():
    with registered(CountingSource):
        report = check_source(CountingSource, spec="count:frames=5")
    assert report.checks == list(SOURCE_CHECKS) and report.seeks == 4
    assert report.refused == invalid_texts(CountingSource) == 5


@pytest.mark.parametrize(
    ("klass", "expected"),
    [
        (LongerThanItSays, r"\[length\] 'count:frames=5': length says 6 frames, a full iteration yielded 5"),
        (OffByOneSeek, r"\[seek\] 'count:frames=5': frames_from\(1\) yields other data for frame 1"),
        (CloseOnce, r"\[close\] 'count:frames=5': a second close\(\) raised RuntimeError: already closed"),
        (StampsBackwards, r"\[rate-stamp\] 'count:frames=5': frame 1's stamp 99.0 is earlier than frame 0's 100.0"),
    ],
    ids=lambda v: v.__name__ if isinstance(v, type) else "",
)
def test_broken_source_is_caught(klass, expected):
    with registered(klass), pytest.raises(AssertionError, match=expected) as info:
        check_source(klass, spec="count:frames=5")
    assert str(info.value).startswith(f"{klass.__name__} [")


def test_an_option_accepted_out_of_its_declared_range_is_caught():
    """The declaration says frames <= 50, but the source's own parsing lets 51 through."""

    class Unbounded(CountingSource):
        @classmethod
        def typed_options(cls, spec):
            if spec.options.get("frames") == "51":
                return {"frames": 51}
            return super().typed_options(spec)

    with registered(Unbounded), pytest.raises(AssertionError, match=r"\[options\] .*count:frames=51 \(one above "
                                                                     r"the hard maximum\) was accepted"):
        check_source(Unbounded, spec="count:frames=5")


# -- declared deviations -----------------------------------------------------------------------------------
class CameraLike(CountingSource):
    """Says it can seek, but starts from the beginning whatever it is asked: as a camera would."""

    expected_failures = {"seek": "a camera cannot seek"}  # noqa: RUF012 - a declaration

    def frames_from(self, index):
        return super().frames_from(0)


def test_a_declared_deviation_is_recorded_with_its_reason():
    with registered(CameraLike):
        report = check_source(CameraLike, spec="count:frames=3")
        assert report.checks == [c for c in SOURCE_CHECKS if c != "seek"]  # it failed, as declared
        (why,) = report.deviations.failed_as_declared.values()
        assert why.startswith("a camera cannot seek (failed as declared: CameraLike [seek] 'count:frames=3': "
                              "frames_from(1) yields frames numbered [0, 1], a full iteration [1, 2]")
        assert report.deviations.passed_anyway == []
        by_check = {c.id: c for c in cases(CameraLike, spec="count:frames=3")}
        assert by_check["CameraLike::seek"]() == "deviated"
        assert by_check["CameraLike::length"]() == "passed"
        with pytest.raises(pytest.xfail.Exception, match="declared deviation: a camera cannot seek"):
            run_case(by_check["CameraLike::seek"])


def test_a_declared_deviation_that_does_not_happen_is_reported(caplog):
    with registered(CountingSource):
        report = check_source(CountingSource, spec="count:frames=3", expected_failures={"close": "it leaks"})
        assert report.deviations.passed_anyway == ["CountingSource::close"]
        assert "passed although expected_failures declares it fails (it leaks)" in caplog.text
        (close,) = [c for c in cases(CountingSource, spec="count:frames=3", expected_failures={"close": "it leaks"})
                    if c.id.endswith("::close")]
        with pytest.raises(AssertionError, match=r"CountingSource::close: declared as an expected failure \(it "
                                                 r"leaks\) but it passed: remove the declaration"):
            close()


def test_a_deviation_must_name_a_check_and_give_a_reason():
    with pytest.raises(ValueError, match=r"unknown checks \['seeking'\]; the checks are \['frames', 'length'"):
        check_source(CountingSource, spec="count:frames=3", expected_failures={"seeking": "no"})
    with pytest.raises(ValueError, match="give each deviation a reason"):
        check_source(CountingSource, spec="count:frames=3", expected_failures={"seek": " "})


# -- broken kinds ------------------------------------------------------------------------------------------
class FloatPreviewKind(ImageKind):
    def preview(self, data):
        return super().preview(data).astype(np.float32)


class AcceptingKind(ImageKind):
    def check_frame(self, data):
        if data is not None:
            super().check_frame(data)


class SameCopyKind(ImageKind):
    def copy_frame(self, data):
        return data


@pytest.mark.parametrize(
    ("kind", "expected"),
    [
        (FloatPreviewKind(), r"kind '2d' \[preview\]: preview\(frame 0\) is a float32 array of shape \(480, 640, 3\)"),
        (AcceptingKind(), r"kind '2d' \[check-frame\]: check_frame accepted None"),
        (SameCopyKind(), r"kind '2d' \[copy-frame\]: copy_frame\(frame 0\) returned the frame itself"),
    ],
    ids=lambda v: type(v).__name__ if not isinstance(v, str) else "",
)
def test_broken_kind_is_caught(kind, expected):
    with pytest.raises(AssertionError, match=expected):
        check_kind(kind)


def test_a_source_spec_of_no_source_fails_clearly():
    with pytest.raises(AssertionError, match=r"\[frames\] 'nosuch:1': cannot be opened: nosuch:1"):
        check_source("nosuch:1", kind="2d")
    with pytest.raises(TypeError, match="give spec= naming something it reads"):
        check_source(type("Nameless", (CountingSource,), {"schemes": ()}))


def test_outlines_are_checked_on_the_kinds_own_detections():
    """The 2D demo frames give the detectors nothing at their defaults (everything passes the default colour
    band); a mask with two blobs gives BinaryDetector two polygons, whose outlines are checked."""
    mask = np.zeros((120, 160), np.uint8)
    mask[20:50, 20:60] = 255
    mask[70:100, 90:140] = 255
    report = check_kind("2d", frames=[mask])
    assert report.outlines == 2 and report.checks == list(KIND_CHECKS)
