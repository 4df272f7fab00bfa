"""A third data kind plugs in with no change to objrec_core or the apps: 1-D signals (tests/signal_kind).

The plug-in is laid out as pip would install it (the package and a dist-info folder with its entry points)
for ``objrec-detect`` in a subprocess, and registered in code for the in-process tests, which remove it
again so that no other test sees the kind.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from objrec_core import (
    DetectionDirector,
    FrameKindError,
    ParameterStorage,
    RecognitionSystem,
    SourceError,
    build_system,
    get_kind,
    kind_names,
    module_type_names,
    open_source,
    register_kind,
    register_module,
    register_source,
    source_kinds,
)
from objrec_core.registry import unregister_kind, unregister_module, unregister_source
from objrec_core.testing import check_module

PLUGIN = Path(__file__).resolve().parents[1] / "signal_kind"
ENTRY_POINTS = """\
[objrec.kinds]
signal = objrec_signal.kind:SignalKind

[objrec.sources]
signal.wave = objrec_signal.sources:WaveSource

[objrec.modules]
MovingAverageFilter = objrec_signal.modules:MovingAverageFilter
PeakDetector = objrec_signal.modules:PeakDetector
"""
PARAMS = """\
format_version: 1
object_name: bump
kind: signal
description: bumps on a noisy line
pipeline:
- type: MovingAverageFilter
  id: smooth
  parameters: {window: 5, edges: reflect}
- type: PeakDetector
  id: peaks
  parameters: {threshold: 0.5, ceiling: 100.0, min_distance: 8}
"""
#: A Gaussian bump of standard deviation 3 samples, averaged over 5 samples, keeps this share of its height.
SMOOTHED = sum(math.exp(-0.5 * (k / 3.0) ** 2) for k in range(-2, 3)) / 5


def install(site: Path) -> Path:
    """Lay the plug-in out in ``site`` as pip would: the package plus a dist-info folder with entry points."""
    site.mkdir(parents=True, exist_ok=True)
    shutil.copytree(PLUGIN / "objrec_signal", site / "objrec_signal", ignore=shutil.ignore_patterns("__pycache__"))
    info = site / "objrec_signal-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: objrec-signal\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(ENTRY_POINTS)
    return site


@contextlib.contextmanager
def signal_plugin() -> Iterator[ModuleType]:
    """The plug-in imported from its source folder (no dist-info there, so no entry points are read in this
    process) and registered in code; afterwards neither the registrations nor the import are left behind."""
    sys.path.insert(0, str(PLUGIN))
    try:
        import objrec_signal

        register_kind(objrec_signal.SignalKind)
        register_source(objrec_signal.WaveSource, "signal.wave")  # its entry point's name
        register_module(objrec_signal.MovingAverageFilter)
        register_module(objrec_signal.PeakDetector)
        yield objrec_signal
    finally:
        unregister_kind("signal")
        unregister_source("signal.wave")
        unregister_module("MovingAverageFilter")
        unregister_module("PeakDetector")
        sys.path.remove(str(PLUGIN))
        for name in [n for n in sys.modules if n == "objrec_signal" or n.startswith("objrec_signal.")]:
            del sys.modules[name]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The plug-in as pip would install it, for subprocesses."""
    return install(tmp_path_factory.mktemp("signal") / "site")


@pytest.fixture
def sig() -> Iterator[ModuleType]:
    with signal_plugin() as module:
        yield module


@pytest.fixture
def params(tmp_path) -> Path:
    path = tmp_path / "bumps.yaml"
    path.write_text(PARAMS)
    return path


def truth_of(seed: int, frames: int) -> list[list[dict]]:
    with open_source(f"wave:seed={seed},frames={frames}", "signal") as source:
        return [frame.truth for frame in source]


def test_the_plugin_is_registered_and_then_gone():
    assert "signal" not in kind_names()
    with signal_plugin():
        assert "signal" in kind_names()
        assert {"MovingAverageFilter", "PeakDetector"} <= set(module_type_names())
        assert source_kinds("wave:seed=2") == ["signal"]
    assert "signal" not in kind_names()
    assert not {"MovingAverageFilter", "PeakDetector"} & set(module_type_names())
    assert source_kinds("wave:seed=2") == []


def test_detection_finds_the_bumps_where_the_source_put_them(sig, params):
    system = build_system(params)
    assert (system.kind, system.object_name, system.description) == ("signal", "bump", "bumps on a noisy line")
    assert [m.id for m in system.modules] == ["smooth", "peaks"]
    director = DetectionDirector(system)
    with open_source("wave:seed=1,frames=5", "signal") as source:
        frames = list(source)
    arrays = [director.process(frame) for frame in frames]
    assert all(isinstance(a, sig.SignalPeakArray) for a in arrays)
    for frame, array in zip(frames, arrays, strict=True):
        assert [o.position for o in array.objects] == [t["position"] for t in frame.truth]
        for found, true in zip(array.objects, frame.truth, strict=True):
            assert found.name == "bump"
            assert found.height == pytest.approx(SMOOTHED * true["height"], abs=0.05)
        assert array.header.frame_id == "signal"
    # seed 1's first frame, in numbers: three bumps at samples 85, 115 and 188
    assert [o.position for o in arrays[0].objects] == [85, 115, 188]
    assert [t["height"] for t in frames[0].truth] == pytest.approx([1.624, 1.847, 2.655], abs=0.001)

    with open_source("wave:seed=1,frames=5", "signal") as source:
        stats = director.run_all(source)
    assert (stats.frames, stats.objects, stats.frames_with_objects, stats.stopped_by) == (5, 15, 5, "end")


def test_the_smoothing_makes_the_difference(sig):
    """On a noisy wave the detector alone finds the noise's wiggles; after a 9-sample average, only the bumps."""
    with open_source("wave:seed=1,frames=1,noise=0.3", "signal") as source:
        frame = next(iter(source))
    truth = [t["position"] for t in frame.truth]
    raw = RecognitionSystem([sig.PeakDetector(threshold=0.5, min_distance=2)]).process(frame.data)
    smoothed = RecognitionSystem([sig.MovingAverageFilter(window=9), sig.PeakDetector(threshold=0.5, min_distance=8)]
                                 ).process(frame.data)
    assert truth == [85, 115, 188]
    assert len(raw.objects) == 18
    assert [o.position for o in smoothed.objects] == [85, 114, 188]  # within a sample of the truth, noise 0.3


def test_parameter_file_round_trip(sig, params, tmp_path):
    system = build_system(params)
    smooth, peaks = system.modules
    smooth.set_parameters(window=7, edges="edge")
    peaks.set_parameters(threshold=0.75, ceiling=2.5, min_distance=12)
    peaks.object_name = "hill"
    saved = tmp_path / "saved.yaml"
    ParameterStorage(system).save_parameters(saved)
    again = build_system(saved)
    assert again.kind == "signal"
    assert [m.get_parameters() for m in again.modules] == [
        {"window": 7, "edges": "edge"},
        {"threshold": 0.75, "ceiling": 2.5, "min_distance": 12},
    ]
    assert again.modules[1].object_name == "hill"
    with open_source("wave:seed=1,frames=1", "signal") as source:
        data = next(iter(source)).data
    before = [o.to_dict() for o in system.process(data).objects]
    after = [o.to_dict() for o in again.process(data).objects]
    assert before == after
    # the highest bump, 2.655, is about 2.17 after a 7-sample average: under the 2.5 ceiling, so none is clipped
    assert [o["position"] for o in after] == [85, 115, 188]
    assert {o["name"] for o in after} == {"hill"}


def test_signal_file_source(sig, tmp_path):
    path = tmp_path / "two.sig"
    path.write_text("# two recorded frames\n0, 0.2, 1, 3, 1, 0.2, 0, 0, 2, 5, 2, 0\n\n1 1 4 1 1 9.5 1  # clipped\n")
    assert source_kinds(str(path)) == ["signal"]
    system = RecognitionSystem([sig.PeakDetector(threshold=0.5, ceiling=9.0, min_distance=2)], object_name="spike")
    with open_source(str(path)) as source:
        assert source.length == 2
        arrays = list(DetectionDirector(system).run(source))
    assert [[(o.position, o.height) for o in a.objects] for a in arrays] == [[(3, 3.0), (9, 5.0)], [(2, 4.0)]]
    bad = tmp_path / "bad.sig"
    bad.write_text("1, 2, x\n")
    with pytest.raises(SourceError, match=r"bad\.sig: line 1: could not convert string to float: 'x'"):
        open_source(str(bad), "signal")


def test_source_errors_name_the_kind_and_the_option(sig):
    expected = r"wave:length=3: option length='3' is invalid: out of range, allowed int in 16\.\.1000000"
    with pytest.raises(SourceError, match=expected):
        open_source("wave:length=3", "signal")
    with pytest.raises(SourceError, match=r"a source of signal data, but this pipeline works on 2d data"):
        open_source("wave:seed=1", "2d")


def test_kind_checks_frames_and_draws_with_numpy(sig):
    kind = get_kind("signal")
    assert isinstance(kind, sig.SignalKind) and kind.object_array_type is sig.SignalPeakArray
    for wrong in (np.zeros((4, 4)), np.arange(5), np.array([], dtype=float), [1.0, 2.0]):
        with pytest.raises(FrameKindError):
            kind.check_frame(wrong)
    ramp = np.linspace(0.0, 1.0, 100)
    picture = kind.preview(ramp)
    margin, height = sig.kind.MARGIN, sig.kind.PLOT_HEIGHT
    assert picture.shape == (height, 100 + 2 * margin, 3) and picture.dtype == np.uint8
    trace = (picture == sig.kind.TRACE).all(axis=2)
    assert np.flatnonzero(trace[:, margin]).tolist() == [height - margin - 1]  # the lowest value, at the bottom
    assert np.flatnonzero(trace[:, margin + 99])[0] == margin  # the highest, at the top
    assert trace.sum() == 100 + (height - 2 * margin - 1)  # one unbroken line: each column, and each row step once

    long = np.zeros(10_000)
    long[5_000] = 1.0  # one sample of 10 000 still shows in a 2048-column plot
    wide = kind.preview(long)
    assert wide.shape[1] == 2000 + 2 * margin
    assert (wide[margin, margin + 1000] == sig.kind.TRACE).all()

    frame = next(iter(open_source("wave:seed=1,frames=1", "signal")))
    array = sig.SignalPeakArray(objects=[sig.SignalPeak("bump", 115, 1.66)])
    annotated = kind.annotate(frame, array)
    marked = (annotated == sig.kind.MARK).all(axis=2)
    assert np.flatnonzero(marked.any(axis=0)).tolist() == [margin + 115]
    assert [o.label for o in kind.outlines(array)] == ["bump @115"]


def test_peak_array_json_round_trip(sig):
    array = sig.SignalPeakArray(objects=[sig.SignalPeak("bump", 85, 1.466), sig.SignalPeak("bump", 188, 2.374)])
    line = array.to_json()
    assert json.loads(line)["objects"][1] == {"name": "bump", "position": 188, "height": 2.374}
    again = sig.SignalPeakArray.from_json(line)
    assert again.objects == array.objects and isinstance(again.objects[0], sig.SignalPeak)


def test_check_module_passes_on_the_plugin_modules(sig):
    smooth = check_module(sig.MovingAverageFilter)
    assert smooth.boundaries >= 5 and smooth.refused >= 15
    peaks = check_module(sig.PeakDetector)
    # threshold at its hard maximum, alone, is above the ceiling: the declared rule refuses it, naming both
    assert peaks.rule_refusals >= 1 and peaks.frames >= 5


def test_rule_refusal_names_both_levels(sig):
    detector = sig.PeakDetector()
    with pytest.raises(ValueError, match=r"PeakDetector: parameter threshold=200\.0 is invalid: must be below "
                                         r"ceiling=100\.0 \(no peak could be reported\)"):
        detector.set_parameters(threshold=200.0)


def test_objrec_detect_runs_the_signal_kind(sig, site, params):
    """The plug-in reaches ``objrec-detect`` through its entry points alone, in a fresh process."""
    env = {**os.environ, "PYTHONPATH": f"{site}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    result = subprocess.run(
        [sys.executable, "-m", "objrec_apps.detect", str(params), "--source", "wave:seed=1,frames=5"],
        capture_output=True, text=True, env=env, timeout=120,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 5
    expected = truth_of(1, 5)
    arrays = [sig.SignalPeakArray.from_json(line) for line in lines]
    assert [[o.position for o in a.objects] for a in arrays] == [[t["position"] for t in f] for f in expected]
    assert [a.header.seq for a in arrays] == [0, 1, 2, 3, 4]
    assert {o.name for a in arrays for o in a.objects} == {"bump"}
    assert arrays[0].objects[2].height == pytest.approx(SMOOTHED * 2.655, abs=0.05)
