"""The objrec-define command: the three systems and parameter files open, and every user mistake is one
clear line on stderr with exit code 2, never a traceback (a missing display included)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication

from objrec_apps import define
from objrec_apps.gui import DefinitionGUI, build_preset
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
    assert f"{path}: pipeline[0].parameters.h_min" in line and "out of range" in line


def test_unknown_systems_missing_files_and_bad_sources_are_user_errors(tmp_path):
    assert "neither one of hsv, feature, shape" in one_error_line(run_define("colour"))
    assert "file not found" in one_error_line(run_define(str(tmp_path / "missing.yaml")))
    assert "camera:N" in one_error_line(run_define("hsv", "--source", "camera:front"))


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
    expected = build_preset(name)
    assert [(m.type_name, m.id) for m in window.system.modules] == [(m.type_name, m.id) for m in expected.modules]
    assert window.system.kind == expected.kind
    assert [p.module.id for p in window.panels.panels] == [m.id for m in expected.modules]


def test_a_parameter_file_opens_with_its_path(opened, tmp_path):
    system = build_preset("hsv")
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
