"""One registry for modules, kinds, sources and tasks: keyed by entry-point name, duplicates refused naming
both distributions, broken plug-ins one clear error, and a 2D run that imports nothing of objrec3d or
objrec_ros.

Plug-in distributions are laid out as pip would install them (a package and a dist-info folder with its
entry points) in a temporary folder put on ``sys.path``, or on ``PYTHONPATH`` for a child process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from declare.registry import PluginError, Registry
from objrec_core import (
    DetectionDirector,
    Filter,
    FrameSource,
    SourceError,
    UnknownModuleError,
    build_system,
    module_type,
    open_source,
    register_module,
    source_types,
)
from objrec_core import registry as core_registry
from objrec_core.registry import register_source, source_entries, source_schemes, unregister_module
from objrec_core.source_declaration import DeclaredSource

PROJECT = Path(__file__).resolve().parents[2]
TEST_GROUP = "objrec.registry_tests"


def install_dist(site: Path, name: str, version: str, entry_points: str, files: dict[str, str]) -> Path:
    """A distribution as pip lays it out: its modules and a dist-info folder naming its entry points."""
    site.mkdir(parents=True, exist_ok=True)
    for path, text in files.items():
        (site / path).parent.mkdir(parents=True, exist_ok=True)
        (site / path).write_text(text)
    info = site / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text(entry_points)
    return site


@pytest.fixture
def site(tmp_path, monkeypatch) -> Iterator[Path]:
    """A folder on sys.path for this test's distributions; the core registry re-reads its entry points on
    the way in and out, so no other test sees them."""
    folder = tmp_path / "site"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    core_registry.refresh()
    yield folder
    monkeypatch.undo()
    for name in [n for n in sys.modules if n.startswith("regtest_")]:
        del sys.modules[name]
    core_registry.refresh()


PLAIN = "VALUE = 1\n"


# -- the generic registry -----------------------------------------------------------------------------------
def test_entry_points_are_keyed_by_name_and_loaded_one_at_a_time(site):
    install_dist(site, "regtest-one", "1.0", f"[{TEST_GROUP}]\nfirst = regtest_first:VALUE\n"
                 "second = regtest_second:VALUE\n",
                 {"regtest_first.py": "VALUE = 'first'\n", "regtest_second.py": "VALUE = 'second'\n"})
    registry: Registry[str] = Registry(TEST_GROUP, "test plug-in")
    assert registry.names() == ["first", "second"]
    assert "regtest_first" not in sys.modules  # listing names imports nothing
    assert registry.get("first") == "first"
    assert "regtest_first" in sys.modules and "regtest_second" not in sys.modules
    with pytest.raises(PluginError, match=r"unknown test plug-in 'third' \(known: first, second\)"):
        registry.get("third")


def test_two_distributions_declaring_one_name_are_refused_naming_both(site):
    install_dist(site, "regtest-alpha", "1.0", f"[{TEST_GROUP}]\nsmooth = regtest_alpha:VALUE\n",
                 {"regtest_alpha.py": PLAIN})
    install_dist(site, "regtest-beta", "2.5", f"[{TEST_GROUP}]\nsmooth = regtest_beta:VALUE\n",
                 {"regtest_beta.py": PLAIN})
    registry: Registry[int] = Registry(TEST_GROUP, "test plug-in")
    assert registry.names() == ["smooth"]
    with pytest.raises(PluginError) as info:
        registry.get("smooth")
    message = str(info.value)
    assert "'smooth' is declared twice" in message
    assert "regtest_alpha:VALUE from regtest-alpha 1.0" in message
    assert "regtest_beta:VALUE from regtest-beta 2.5" in message
    assert registry.items() == {}  # listing every plug-in skips the clash (and logs it)


def test_a_broken_plugin_is_one_error_naming_the_entry_point(site):
    install_dist(site, "regtest-broken", "0.3", f"[{TEST_GROUP}]\nbroken = regtest_missing:Thing\n"
                 "typo = regtest_typo:Nothing\n", {"regtest_typo.py": PLAIN})
    registry: Registry[int] = Registry(TEST_GROUP, "test plug-in")
    with pytest.raises(PluginError, match=r"test plug-in 'broken' = regtest_missing:Thing \(from regtest-broken "
                                          r"0.3\) cannot be loaded: ModuleNotFoundError"):
        registry.get("broken")
    with pytest.raises(PluginError, match=r"'typo' = regtest_typo:Nothing .* AttributeError"):
        registry.get("typo")


def test_the_validation_hook_checks_and_converts_what_is_loaded(site):
    install_dist(site, "regtest-valid", "1.0", f"[{TEST_GROUP}]\nthree = regtest_valid:THREE\n"
                 "text = regtest_valid:TEXT\n", {"regtest_valid.py": "THREE = 3\nTEXT = 'x'\n"})

    def whole_number(name: str, obj: object) -> int:
        if not isinstance(obj, int):
            raise TypeError(f"{obj!r} is not a whole number")
        return obj * 10

    registry: Registry[int] = Registry(TEST_GROUP, "number", validate=whole_number, error=LookupError)
    assert registry.get("three") == 30
    with pytest.raises(LookupError, match=r"number 'text' = regtest_valid:TEXT \(from regtest-valid 1.0\): "
                                          r"'x' is not a whole number"):
        registry.get("text")
    with pytest.raises(TypeError, match="not a whole number"):
        registry.register("y", "why")


def test_code_registrations_clash_with_other_objects_only(site):
    install_dist(site, "regtest-code", "1.0", f"[{TEST_GROUP}]\ninstalled = regtest_code:Installed\n",
                 {"regtest_code.py": "class Installed:\n    pass\n"})
    registry: Registry[type] = Registry(TEST_GROUP, "test plug-in", name_of=lambda cls: cls.__name__.lower())

    class Mine:
        pass

    class Other:
        pass

    assert registry.register(Mine) is Mine
    assert registry.register(Mine) is Mine  # the same object again is no clash
    with pytest.raises(PluginError, match=r"'mine' is already registered by .*Mine; .*Other cannot take its name"):
        registry.register(Other, "mine")
    with pytest.raises(PluginError, match=r"'installed' is installed as regtest_code:Installed from regtest-code "
                                          r"1.0; .*Other cannot take its name"):
        registry.register(Other, "installed")
    import regtest_code

    registry.register(regtest_code.Installed, "installed")  # the entry point's own object
    registry.unregister("mine")
    registry.register(Other, "mine")
    assert registry.get("mine") is Other


def test_a_plugin_is_shadowed_only_inside_replaced(site):
    install_dist(site, "regtest-shadow", "1.0", f"[{TEST_GROUP}]\nthing = regtest_shadow:VALUE\n",
                 {"regtest_shadow.py": PLAIN})
    registry: Registry[object] = Registry(TEST_GROUP, "test plug-in")
    with registry.replaced("thing", 2) as held:
        assert held == 2 and registry.get("thing") == 2
        with registry.replaced("thing", 3):
            assert registry.get("thing") == 3
        assert registry.get("thing") == 2
    assert registry.get("thing") == 1
    with registry.replaced("new", 4):
        assert "new" in registry.names()
    assert "new" not in registry.names()


def test_refresh_reads_entry_points_installed_since(site):
    registry: Registry[int] = Registry(TEST_GROUP, "test plug-in")
    assert registry.names() == []
    install_dist(site, "regtest-late", "1.0", f"[{TEST_GROUP}]\nlate = regtest_late:VALUE\n",
                 {"regtest_late.py": PLAIN})
    assert registry.names() == []  # read once
    registry.refresh()
    assert registry.names() == ["late"] and registry.get("late") == 1


def test_concurrent_look_ups_load_one_object(site):
    install_dist(site, "regtest-threads", "1.0", f"[{TEST_GROUP}]\nobj = regtest_threads:make\n",
                 {"regtest_threads.py": "CALLS = []\n\ndef make():\n    CALLS.append(1)\n    return object()\n"})
    registry: Registry[object] = Registry(TEST_GROUP, "test plug-in", validate=lambda _name, make: make())
    start = threading.Barrier(8)
    found: list[object] = []

    def look_up() -> None:
        start.wait()
        found.append(registry.get("obj"))

    threads = [threading.Thread(target=look_up) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    assert len(found) == 8 and len({id(o) for o in found}) == 1  # every caller got the object kept


# -- modules, kinds and sources -----------------------------------------------------------------------------
def test_a_second_hsvfilter_entry_point_is_refused_naming_both_distributions(site):
    install_dist(site, "regtest-hsv", "0.9", "[objrec.modules]\nHSVFilter = regtest_hsv:HSVFilter\n",
                 {"regtest_hsv.py": "from objrec2d import HSVFilter\n"})
    with pytest.raises(UnknownModuleError) as info:
        module_type("HSVFilter")
    message = str(info.value)
    assert "module type 'HSVFilter' is declared twice" in message
    assert "objrec2d.hsv_filter:HSVFilter from objrec 0.1.0" in message
    assert "regtest_hsv:HSVFilter from regtest-hsv 0.9" in message
    assert module_type("MorphologyFilter").__name__ == "MorphologyFilter"  # the other names are unharmed


def test_a_second_source_entry_point_of_the_same_name_is_refused_naming_both_distributions(site):
    install_dist(site, "regtest-demo", "2.0", '[objrec.sources]\n2d.demo = regtest_demo:Demo\n',
                 {"regtest_demo.py": "from objrec2d.sources import DemoSource as Demo\n"})
    with pytest.raises(SourceError) as info:
        open_source("demo:frames=1", "2d")
    message = str(info.value)
    assert message.startswith("demo:frames=1: source type '2d.demo' is declared twice")
    assert "from objrec 0.1.0" in message and "regtest_demo:Demo from regtest-demo 2.0" in message
    with open_source("demo:frames=1", "3d") as cloud:  # another kind's sources are unharmed
        assert cloud.length == 1


def test_a_module_registered_in_code_may_not_take_an_installed_name():
    class HSVFilter(Filter):
        kind = "2d"

        def filter(self, frame):
            return frame

    with pytest.raises(UnknownModuleError, match=r"'HSVFilter' is installed as objrec2d.hsv_filter:HSVFilter from "
                                                 r"objrec 0.1.0; .*HSVFilter cannot take its name"):
        register_module(HSVFilter)
    assert module_type("HSVFilter").__module__ == "objrec2d.hsv_filter"
    with pytest.raises(TypeError, match="not a Parametrizable subclass"):
        register_module(int)  # type: ignore[type-var]
    unregister_module("never-registered")  # unknown names are ignored


def test_an_entry_point_whose_class_declares_another_type_name_is_refused(site):
    install_dist(site, "regtest-misnamed", "1.0", "[objrec.modules]\nSharpen = regtest_misnamed:Blur\n",
                 {"regtest_misnamed.py": "from objrec_core import Filter\n\nclass Blur(Filter):\n    kind = '2d'\n"
                                         "\n    def filter(self, frame):\n        return frame\n"})
    with pytest.raises(UnknownModuleError, match=r"module type 'Sharpen' = regtest_misnamed:Blur \(from "
                                                 r"regtest-misnamed 1.0\): declares type_name 'Blur'"):
        module_type("Sharpen")


MYDEMO = '''\
import numpy as np
from objrec_core import Frame, FrameSource, Int


class DemoSource(FrameSource):
    """A plug-in source whose class shares its name with the built-in demo sources."""

    kind = "2d"
    schemes = ("mydemo",)
    options = {"frames": Int(3, "frames", min=1, max=10)}

    @classmethod
    def from_spec(cls, spec, options):
        source = cls()
        source.name, source.frames = spec.text, options["frames"]
        return source

    @property
    def length(self):
        return self.frames

    def __iter__(self):
        for i in range(self.frames):
            yield Frame(np.full((2, 2), 7, np.uint8), index=i, source=self.name)
'''


def test_a_plugin_source_class_named_demosource_is_found_by_its_entry_point_name(site):
    """Regression: sources were keyed ``kind.ClassName``, so this plug-in shadowed (or was shadowed by) the
    built-in ``2d.demo`` and ``mydemo:`` was unknown."""
    install_dist(site, "regtest-mydemo", "1.0", "[objrec.sources]\n2d.mydemo = regtest_mydemo:DemoSource\n",
                 {"regtest_mydemo.py": MYDEMO})
    with open_source("mydemo:frames=2", "2d") as source:
        assert type(source).__module__ == "regtest_mydemo"
        assert [int(f.data[0, 0]) for f in source] == [7, 7]
    with open_source("demo:frames=1", "2d") as source:
        assert type(source).__module__ == "objrec2d.sources"
    names = {t.__module__ for t in source_types("2d") if t.__name__ == "DemoSource"}
    assert names == {"objrec2d.sources", "regtest_mydemo"}
    assert {"2d.demo", "2d.mydemo"} <= set(source_entries("2d"))


def test_a_source_entry_point_of_another_kind_than_its_name_is_refused(site):
    install_dist(site, "regtest-wrongkind", "1.0", "[objrec.sources]\n3d.mydemo = regtest_wrongkind:DemoSource\n",
                 {"regtest_wrongkind.py": MYDEMO})
    with pytest.raises(UnknownModuleError, match=r"source type '3d.mydemo' = regtest_wrongkind:DemoSource \(from "
                                                 r"regtest-wrongkind 1.0\): is a source of kind '2d'"):
        core_registry.SOURCES.get("3d.mydemo")
    assert "mydemo" not in source_schemes("3d")  # listed sources skip it (and log why)


def test_register_source_takes_an_explicit_name():
    class TickSource(FrameSource):
        kind = "2d"
        schemes = ("tick",)

    register_source(TickSource, "2d.tick")
    try:
        assert source_entries("2d")["2d.tick"] is TickSource
        assert "tick" in source_schemes("2d") and "tick" not in source_schemes("3d")
    finally:
        core_registry.unregister_source("2d.tick")
    assert "2d.tick" not in source_entries("2d")


def test_bag_sources_are_declared_without_importing_their_implementation():
    entries = source_entries("2d")
    bag = entries["2d.bag"]
    assert isinstance(bag, DeclaredSource) and bag.implementation == "objrec2d.bag_source:ImageBagSource"
    assert isinstance(source_entries("3d")["3d.bag"], DeclaredSource)
    # Each declaration matches its implementation (loading checks kind, schemes, extensions, folders).
    for name in ("2d.bag", "3d.bag"):
        declared = core_registry.SOURCES.get(name)
        klass = declared.load()
        assert klass.summary == declared.summary and klass.kind == name[:2]


def test_a_declared_source_is_known_before_and_named_when_its_implementation_is_broken(site):
    install_dist(site, "regtest-decl", "1.0", "[objrec.sources]\n2d.broken = regtest_decl:DECLARED\n",
                 {"regtest_decl.py": "from objrec_core.source_declaration import DeclaredSource\n"
                                     "DECLARED = DeclaredSource(kind='2d', implementation='regtest_gone:Source', "
                                     "schemes=('brk',))\n"})
    assert "brk:" in core_registry.source_usage("2d") and "brk" not in source_schemes("3d")
    with pytest.raises(SourceError, match=r"^brk:1: source type '2d.broken' = regtest_gone:Source \(declared by "
                                          r"regtest_decl:DECLARED from regtest-decl 1.0\) cannot be loaded: "
                                          r"ModuleNotFoundError"):
        open_source("brk:1", "2d")


def test_a_declaration_that_drifted_from_its_implementation_is_refused(tmp_path):
    drifted = DeclaredSource(kind="2d", implementation="objrec2d.sources:DemoSource", schemes=("demo", "extra"))
    with pytest.raises(TypeError, match=r"objrec2d.sources:DemoSource declares kind, schemes, extensions"):
        drifted.load()
    bags = DeclaredSource(kind="2d", implementation="x:Y", extensions=(".BAG",), folder_marker="metadata.yaml")
    (tmp_path / "ros2").mkdir()
    (tmp_path / "ros2" / "metadata.yaml").write_text("")
    (tmp_path / "images").mkdir()
    (tmp_path / "run.bag").write_text("")
    assert [bags.path_score(tmp_path / p) for p in ("ros2", "images", "run.bag")] == [2, 0, 2]


def test_another_kinds_scheme_is_an_error_naming_that_kind():
    with pytest.raises(SourceError, match=r"^rgbd:a.png,b.png: a source of 3d data, but this pipeline works on "
                                          r"2d data$"):
        open_source("rgbd:a.png,b.png", "2d")
    with pytest.raises(SourceError, match=r"^camera:0: a source of 2d data, but this pipeline works on 3d data$"):
        open_source("camera:0", "3d")


# -- a 2D run imports nothing of objrec3d or objrec_ros -------------------------------------------------------
TWO_D_RUN = """\
import itertools, json, sys
import objrec_core, objrec2d
from objrec_core import DetectionDirector, build_system, open_source

with open_source("demo:seed=2,frames=3", "2d") as source:
    assert type(source).__module__ == "objrec2d.sources", type(source)
system = build_system(sys.argv[1])
with open_source("demo:frames=3", system.kind) as frames:
    counts = [len(objects.objects) for objects in DetectionDirector(system).run(frames)]
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("objrec3d", "objrec_ros", "open3d", "rosbags"))
print(json.dumps({"counts": counts, "loaded": loaded}))
"""

DETECT_RUN = """\
import json, sys
from objrec_apps.launch import detect

sys.argv = ["objrec-detect", sys.argv[1], "--source", "demo", "--max-frames", "3"]
try:
    code = detect()
except SystemExit as exc:
    code = exc.code
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("objrec3d", "objrec_ros", "open3d", "rosbags"))
print(json.dumps({"code": code, "loaded": loaded}), file=sys.stderr)
"""


def _child(script: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, cwd=PROJECT,
                          env={**os.environ, "PYTHONPATH": str(PROJECT)}, timeout=300)


def test_a_2d_run_imports_no_objrec3d_or_objrec_ros_module():
    result = _child(TWO_D_RUN, str(PROJECT / "params" / "hsv_demo.yaml"))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout.splitlines()[-1])
    assert report["loaded"] == []
    assert len(report["counts"]) == 3 and all(c > 0 for c in report["counts"])


def test_objrec_detect_on_a_2d_file_imports_no_objrec3d_or_objrec_ros_module():
    result = _child(DETECT_RUN, str(PROJECT / "params" / "hsv_demo.yaml"))
    report = json.loads(result.stderr.strip().splitlines()[-1])
    assert report == {"code": 0, "loaded": []}, result.stderr
    assert len([line for line in result.stdout.splitlines() if line.startswith("{")]) == 3


def test_in_process_2d_run_builds_and_detects():
    """The same run in process (the child tests above prove what it leaves unimported)."""
    system = build_system(PROJECT / "params" / "hsv_demo.yaml")
    with open_source("demo:frames=2", system.kind) as frames:
        assert [len(o.objects) > 0 for o in DetectionDirector(system).run(frames)] == [True, True]
