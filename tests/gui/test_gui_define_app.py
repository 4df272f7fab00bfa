"""The objrec-define command: the three shipped systems (untitled: Save asks where) and parameter files
open, and every user mistake is one clear line on stderr with exit code 2, never a traceback (a missing
display included)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication, QFileDialog

from objrec_apps import define
from objrec_apps.define import starting_system
from objrec_apps.gui import DefinitionGUI
from objrec_core import ParameterStorage


def run_define(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    environment = dict(os.environ, QT_QPA_PLATFORM="offscreen") if env is None else env
    return subprocess.run([sys.executable, "-m", "objrec_apps.define", *args], capture_output=True, text=True,
                          env=environment, timeout=60)


def one_error_line(result: subprocess.CompletedProcess[str]) -> str:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("objrec-define: error: "), result.stderr
    assert "Traceback" not in result.stderr
    return lines[0]


def test_a_broken_parameter_file_is_one_line_and_exit_code_2(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("format_version: 1\nkind: 2d\npipeline:\n- type: HSVFilter\n  parameters: {h_min: 300}\n")
    line = one_error_line(run_define(str(path)))
    assert f"{path}:5: pipeline[0].parameters.h_min" in line and "out of range" in line


def test_unknown_systems_missing_files_and_bad_sources_are_user_errors(tmp_path):
    assert "neither one of hsv, feature, shape" in one_error_line(run_define("colour"))
    assert "file not found" in one_error_line(run_define(str(tmp_path / "missing.yaml")))
    line = one_error_line(run_define("hsv", "--source", "camera:front"))
    assert "camera:front: option index='front' is invalid: expected int" in line
    line = one_error_line(run_define("hsv", "--source", "rgbd:color.png,depth.png"))
    assert "a source of 3d data, but this pipeline works on 2d data" in line


def test_no_display_is_a_clear_message():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    line = one_error_line(run_define("hsv", env=env))
    assert "no display" in line and "xvfb-run" in line


def test_help_works_as_a_module_and_as_the_console_script():
    result = run_define("--help")
    assert result.returncode == 0 and "hsv|feature|shape|PARAMS_FILE" in result.stdout
    script = Path(sys.executable).with_name("objrec-define")
    if script.exists():
        assert "--source" in subprocess.run([str(script), "--help"], capture_output=True, text=True).stdout


@pytest.fixture
def opened(monkeypatch, qapp, tmp_path):
    """Run ``main`` in this process with the event loop replaced, and hand back the window it showed."""
    windows: list[DefinitionGUI] = []
    monkeypatch.setattr(DefinitionGUI, "show", lambda self: windows.append(self))
    monkeypatch.setattr(QApplication, "exec", lambda self: 0)
    monkeypatch.setattr("objrec_apps.gui.main_window.default_settings",
                        lambda: QSettings(str(tmp_path / "settings.ini"), QSettings.Format.IniFormat))
    yield windows
    for window in windows:
        window.close()


@pytest.mark.parametrize("name", ["hsv", "feature", "shape"])
def test_the_three_systems_open(opened, name):
    assert define.main([name, "--paused"]) == 0
    (window,) = opened
    expected = starting_system(name)
    assert [(m.type_name, m.id) for m in window.system.modules] == [(m.type_name, m.id) for m in expected.modules]
    assert [m.get_parameters() for m in window.system.modules] == [m.get_parameters() for m in expected.modules]
    assert window.system.kind == expected.kind and window.system.object_name == expected.object_name
    assert [p.module.id for p in window.panels.panels] == [m.id for m in expected.modules]
    assert window.files.path is None and window.files.origin == f"{name}_demo.yaml"
    assert f"untitled, from the shipped {name}_demo.yaml" in window.windowTitle()


def test_the_shipped_systems_are_the_package_data_files():
    root = Path(define.__file__).parent / "systems"
    assert sorted(define.SYSTEMS.values()) == sorted(p.name for p in root.glob("*.yaml"))
    system = starting_system("hsv")
    assert system.module("colour").get_parameters()["s_min"] == 120 and system.object_name == "coloured_object"
    with pytest.raises(KeyError):
        starting_system("colour")


def test_save_of_a_shipped_system_asks_where_and_leaves_the_shipped_file_alone(opened, monkeypatch, tmp_path):
    shipped = Path(define.__file__).parent / "systems" / "hsv_demo.yaml"
    before = shipped.read_bytes()
    assert define.main(["hsv", "--paused"]) == 0
    (window,) = opened
    window.files.remember_folder(tmp_path)
    asked: list[str] = []
    target = tmp_path / "mine.yaml"

    def get_save(parent, caption, start, filters):
        asked.append(start)
        return str(target), filters

    monkeypatch.setattr(QFileDialog, "getSaveFileName", staticmethod(get_save))
    window.system.module("colour").set_parameters(s_min=90)
    window.save_action.trigger()
    assert asked == [str(tmp_path / "hsv_demo.yaml")]  # Save asked, suggesting the shipped file's name
    assert shipped.read_bytes() == before
    assert starting_system("hsv").module("colour").s_min == 120
    assert window.files.path == target and "mine.yaml" in window.windowTitle() and "shipped" not in window.windowTitle()
    window.save_action.trigger()  # now it has a file: no dialog
    assert len(asked) == 1


def test_an_empty_window_waits_for_a_kind_before_opening_the_demo(opened):
    assert define.main(["--paused"]) == 0
    (window,) = opened
    assert window.system.modules == () and window.worker.source is None
    assert window.statusBar().currentMessage().startswith("demo is a source of images (2d) and point clouds (3d)")


def test_a_parameter_file_opens_with_its_path(opened, tmp_path):
    system = starting_system("hsv")
    system.module("colour").set_parameters(h_min=20, h_max=40)
    path = tmp_path / "yellow.yaml"
    ParameterStorage(system).save_parameters(path)
    assert define.main([str(path), "--paused", "--view", "grid"]) == 0
    (window,) = opened
    assert window.system.module("colour").get_parameters()["h_max"] == 40
    assert window.files.path == path and window.stage_views.mode == "grid"
    assert "yellow.yaml" in window.windowTitle()


def test_missing_x11_libraries_are_named_with_their_packages(monkeypatch):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(define, "missing_xcb_packages", lambda: ["libxcb-icccm4", "libxcb-keysyms1"])
    with pytest.raises(define.UserError, match="sudo apt-get install libxcb-icccm4 libxcb-keysyms1"):
        define.check_display()
    monkeypatch.setattr(define, "missing_xcb_packages", lambda: [])
    define.check_display()  # all there: no complaint
    assert set(define.XCB_LIBRARIES.values()) >= {"libxcb-cursor0", "libxcb-icccm4", "libxcb-keysyms1"}
