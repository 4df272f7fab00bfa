"""ParameterStorage: round trips, two modules of one class, all-or-nothing loading, atomic saves, and a
clear ParameterFileError with the key path for every kind of bad file."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

from objrec2d import BinaryDetector, HSVFilter, MorphologyFilter
from objrec_core import (
    Detector,
    Filter,
    Int,
    ParameterFileError,
    ParameterStorage,
    RecognitionSystem,
    build_system,
    register_module,
)


def colour_system() -> RecognitionSystem:
    return RecognitionSystem(
        [
            HSVFilter(id="hsv", h_min=100, h_max=130, s_min=120),
            MorphologyFilter(id="open", operation="open", kernel_size=5),
            MorphologyFilter(id="close", operation="close", iterations=3),
            BinaryDetector(id="blobs", min_contour_length=80.0),
        ],
        object_name="blue_candy",
    )


def save(system: RecognitionSystem, path: Path) -> Path:
    ParameterStorage(system).save_parameters(path)
    return path


def edit(path: Path, change) -> None:
    doc = yaml.safe_load(path.read_text())
    change(doc)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))


def test_round_trip_with_two_modules_of_one_class(tmp_path):
    path = save(colour_system(), tmp_path / "blue.yaml")
    doc = yaml.safe_load(path.read_text())
    assert doc["format_version"] == 1 and doc["kind"] == "2d" and doc["object_name"] == "blue_candy"
    assert [(e["type"], e["id"]) for e in doc["pipeline"]] == [
        ("HSVFilter", "hsv"),
        ("MorphologyFilter", "open"),
        ("MorphologyFilter", "close"),
        ("BinaryDetector", "blobs"),
    ]
    rebuilt = build_system(path)
    assert rebuilt.module("open").get_parameters() == {
        "operation": "open",
        "iterations": 1,
        "kernel_size": 5,
        "kernel_shape": "rect",
    }
    assert rebuilt.module("close").get_parameters()["iterations"] == 3
    assert rebuilt.module("hsv").get_parameters()["h_max"] == 130
    assert rebuilt.detectors[0].object_name == "blue_candy"
    # Loading into an existing system of the same shape changes its values in place.
    target = colour_system()
    target.module("close").set_parameters(iterations=9)
    ParameterStorage(target).load_parameters(path)
    assert target.module("close").iterations == 3


def test_loading_is_all_or_nothing(tmp_path):
    path = save(colour_system(), tmp_path / "p.yaml")

    def break_one(doc):
        doc["pipeline"][0]["parameters"]["h_min"] = 5  # a valid change before the bad one
        doc["pipeline"][2]["parameters"]["iterations"] = -4

    edit(path, break_one)
    system = colour_system()
    before = [m.get_parameters() for m in system.modules]
    with pytest.raises(ParameterFileError) as info:
        ParameterStorage(system).load_parameters(path)
    assert info.value.key_path == "pipeline[2].parameters.iterations"
    assert str(path) in str(info.value) and "-4 is invalid" in str(info.value)
    assert "0..20" in str(info.value)
    assert [m.get_parameters() for m in system.modules] == before


@pytest.mark.parametrize(
    ("content", "key_path", "fragment"),
    [
        ("format_version: 1\nkind: 2d\npipeline: [\n", "line", "not valid YAML"),
        ("- just\n- a list\n", "", "mapping at the top"),
        ("format_version: 1\nkind: 2d\npipeline:\n- type: NoSuchFilter\n", "pipeline[0].type", "unknown module type"),
        (
            "format_version: 1\nkind: 2d\npipeline:\n- type: HSVFilter\n  parameters: {h_min: low}\n",
            "pipeline[0].parameters.h_min",
            "expected an integer",
        ),
        (
            "format_version: 1\nkind: 2d\npipeline:\n- type: HSVFilter\n  parameters: {hue_min: 3}\n",
            "pipeline[0].parameters.hue_min",
            "no such parameter",
        ),
        (
            "format_version: 1\nkind: 2d\npipeline:\n- type: HSVFilter\n  colour: red\n",
            "pipeline[0].colour",
            "unknown key",
        ),
        ("format_version: 1\nkind: 2d\nextra: 1\npipeline: []\n", "extra", "unknown key"),
        ("format_version: 7\nkind: 2d\npipeline: []\n", "format_version", "newer"),
        ("format_version: 1\nkind: 4d\npipeline: []\n", "kind",
         "bad.yaml:2: kind: '4d' is invalid: expected one of 2d, 3d"),
        ("format_version: 1\nkind: 2d\npipeline: []\n", "pipeline", "empty"),
        ("kind: 2d\npipeline: []\n", "format_version", "missing"),
        (
            "format_version: 1\nkind: 2d\npipeline:\n- {type: HSVFilter, id: a}\n- {type: HSVFilter, id: a}\n",
            "pipeline[1].id",
            "used twice",
        ),
        (
            "format_version: 1\nkind: 2d\npipeline:\n- {type: HSVFilter, id: 'two words'}\n",
            "pipeline[0].id",
            "invalid",
        ),
        (
            "format_version: 1\nkind: 2d\npipeline:\n- {type: HSVFilter, object_name: x}\n",
            "pipeline[0].object_name",
            "only detectors",
        ),
    ],
)
def test_bad_files_name_the_key_path(tmp_path, content, key_path, fragment):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(ParameterFileError) as info:
        build_system(path)
    assert info.value.key_path.startswith(key_path)
    assert fragment in str(info.value)
    assert str(path) in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(ParameterFileError, match="file not found"):
        build_system(tmp_path / "absent.yaml")


def test_python_tags_are_refused_and_never_run(tmp_path):
    marker = tmp_path / "ran"
    path = tmp_path / "evil.yaml"
    path.write_text(f"format_version: 1\nkind: 2d\npipeline:\n- !!python/object/apply:os.system ['touch {marker}']\n")
    with pytest.raises(ParameterFileError) as info:
        build_system(path)
    assert "line 4" in info.value.key_path
    assert "not allowed" in str(info.value)
    assert not marker.exists()


def test_a_3d_module_in_a_2d_file_is_refused(tmp_path):
    @register_module
    class CloudThing(Filter):
        kind = "3d"

        def filter(self, frame):
            return frame

    path = tmp_path / "mixed.yaml"
    path.write_text("format_version: 1\nkind: 2d\npipeline:\n- type: CloudThing\n")
    with pytest.raises(ParameterFileError, match="works on 3d data"):
        build_system(path)


def test_loading_a_different_pipeline_into_a_system_is_refused(tmp_path):
    path = save(colour_system(), tmp_path / "p.yaml")
    other = RecognitionSystem([HSVFilter(id="hsv"), BinaryDetector(id="blobs")])
    with pytest.raises(ParameterFileError, match="open it as a new system"):
        ParameterStorage(other).load_parameters(path)
    assert [m.id for m in other.modules] == ["hsv", "blobs"]
    # ... but load_system replaces the pipeline as a whole.
    ParameterStorage(other).load_system(path)
    assert [m.id for m in other.modules] == ["hsv", "open", "close", "blobs"]


@register_module
class Stamped(Detector):
    """A detector with non-scalar state, to exercise the storage hooks."""

    kind = "2d"
    size = Int(2, "how many bytes of state are expected", min=1, max=64)

    def __init__(self, id=None, **kw):
        self.blob: bytes | None = None
        super().__init__(id, **kw)

    def detect(self, frame):
        return []

    def get_state(self):
        return None if self.blob is None else {"blob": self.blob}

    def prepare_state(self, state, parameters):
        if state is None:
            return None
        blob = state.get("blob")
        if not isinstance(blob, bytes) or len(blob) != parameters["size"]:
            raise ValueError(f"blob must be {parameters['size']} bytes")
        return blob

    def apply_state(self, prepared):
        self.blob = prepared


def test_state_round_trips_and_bad_state_changes_nothing(tmp_path):
    detector = Stamped(id="d", size=3)
    detector.blob = b"\x00\xffA"
    system = RecognitionSystem([HSVFilter(id="h", h_min=4), detector], object_name="thing")
    path = save(system, tmp_path / "s.yaml")
    assert "!!binary" in path.read_text()
    assert build_system(path).module("d").blob == b"\x00\xffA"

    edit(path, lambda doc: doc["pipeline"][1]["parameters"].update(size=5))
    system.module("h").h_min = 9
    with pytest.raises(ParameterFileError) as info:
        ParameterStorage(system).load_parameters(path)
    assert info.value.key_path == "pipeline[1].state" and "5 bytes" in str(info.value)
    assert system.module("h").h_min == 9 and detector.blob == b"\x00\xffA"


def test_detector_object_names_default_to_the_system_and_may_differ(tmp_path):
    a, b = BinaryDetector(id="a"), BinaryDetector(id="b", object_name="special")
    system = RecognitionSystem([HSVFilter(), a, b], object_name="general")
    assert (a.object_name, b.object_name) == ("general", "special")
    path = save(system, tmp_path / "names.yaml")
    rebuilt = build_system(path)
    assert [d.object_name for d in rebuilt.detectors] == ["general", "special"]
    rebuilt.object_name = "renamed"
    assert [d.object_name for d in rebuilt.detectors] == ["renamed", "special"]


def test_save_is_atomic_when_the_process_is_killed_halfway(tmp_path):
    path = save(colour_system(), tmp_path / "keep.yaml")
    original = path.read_text()
    # A child process starts saving a large file and is SIGKILLed after writing part of it.
    child = textwrap.dedent(
        f"""
        import os, signal
        from objrec_core import ParameterStorage, RecognitionSystem
        from strictio import atomic
        from objrec2d import HSVFilter, BinaryDetector
        system = RecognitionSystem([HSVFilter(id="hsv", h_min=1), BinaryDetector(id="blobs")], description="x" * 200000)
        real_fdopen = os.fdopen
        def dying_fdopen(fd, *a, **k):
            stream = real_fdopen(fd, *a, **k)
            write = stream.write
            def half(text):
                write(text[: len(text) // 2]); stream.flush()
                os.kill(os.getpid(), signal.SIGKILL)
            stream.write = half
            return stream
        atomic.os.fdopen = dying_fdopen
        ParameterStorage(system).save_parameters({str(path)!r})
        """
    )
    result = subprocess.run([sys.executable, "-c", child], capture_output=True, timeout=60)
    assert result.returncode == -signal.SIGKILL
    assert path.read_text() == original
    assert build_system(path).module("hsv").h_min == 100
    leftovers = [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert leftovers and all(len(p.read_text()) > 0 for p in leftovers)  # the half-written temporary


def test_save_into_a_missing_folder_is_a_clear_error(tmp_path):
    with pytest.raises(ParameterFileError, match="does not exist"):
        ParameterStorage(colour_system()).save_parameters(tmp_path / "no" / "such" / "p.yaml")
