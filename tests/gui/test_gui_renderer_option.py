"""objrec-define --renderer auto|opengl|software: the 3D view's renderer chosen on the command line, shown in
--help, winning over OBJREC_RENDERER (a variable may be left over from a shell profile; an option is meant
now), and a bad value one line with exit code 2."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication

from objrec_apps import define
from objrec_apps.gui import DefinitionGUI, render_path
from objrec_apps.gui.render_path import choose_render_path
from tests.gui.test_gui_define_app import one_error_line, run_define

ROOT = Path(__file__).resolve().parents[2]
GPU = "NVIDIA GeForce GTX 1650/PCIe/SSE2 (NVIDIA Corporation)"
LLVMPIPE = "llvmpipe (LLVM 15.0.6, 256 bits) (Mesa)"


@pytest.fixture(autouse=True)
def no_command_line_choice():
    """The command line's choice is kept for the process: no test leaves one behind for the next."""
    render_path.ask(None)
    yield
    render_path.ask(None)


def test_the_option_is_in_the_help():
    result = run_define("--help")
    assert result.returncode == 0
    assert "--renderer {auto,opengl,software}" in result.stdout
    assert "OBJREC_RENDERER" in result.stdout


def test_a_bad_renderer_is_one_line_and_exit_code_2():
    line = one_error_line(run_define("shape", "--renderer", "fast"))
    assert line == ("objrec-define: error: --renderer: invalid choice: 'fast' "
                    "(choose from 'auto', 'opengl', 'software')")
    with pytest.raises(ValueError, match="--renderer: 'fast' is not one of auto, opengl, software"):
        render_path.ask("fast")


def test_the_command_line_wins_over_the_environment(monkeypatch):
    monkeypatch.setenv("OBJREC_RENDERER", "opengl")
    render_path.ask("software")
    path = choose_render_path(None, GPU)
    assert not path.opengl and path.reason == "asked for (--renderer software)"
    monkeypatch.setenv("OBJREC_RENDERER", "software")
    monkeypatch.setenv("OBJREC_GL", "0")
    render_path.ask("opengl")
    path = choose_render_path(None, LLVMPIPE)
    assert path.opengl and path.reason == "asked for (--renderer opengl)"
    render_path.ask("auto")  # auto on the command line: the machine decides, whatever the environment says
    assert not choose_render_path(None, LLVMPIPE).opengl and choose_render_path(None, GPU).opengl
    render_path.ask(None)  # no option: the environment decides again
    assert choose_render_path(None, GPU).reason == "asked for (OBJREC_GL=0)"


def test_objrec_define_passes_the_option_to_the_3d_view(monkeypatch, qapp, tmp_path):
    windows: list[DefinitionGUI] = []
    monkeypatch.setattr(DefinitionGUI, "show", lambda self: windows.append(self))
    monkeypatch.setattr(QApplication, "exec", lambda self: 0)
    monkeypatch.setattr("objrec_apps.gui.main_window.default_settings",
                        lambda: QSettings(str(tmp_path / "settings.ini"), QSettings.Format.IniFormat))
    monkeypatch.setenv("OBJREC_RENDERER", "opengl")
    try:
        assert define.main(["shape", "--paused", "--renderer", "software"]) == 0
        (window,) = windows
        assert window.view3d.cloud_view.render_path.reason == "asked for (--renderer software)"
    finally:
        for window in windows:
            window.close()


WINDOW_SCRIPT = textwrap.dedent("""
    import json, sys
    from PySide6.QtWidgets import QApplication
    from objrec_apps import define
    from objrec_apps.gui import DefinitionGUI
    from objrec_apps.gui.gl_cloud_view import GLCloudView
    shown = []
    DefinitionGUI.show = lambda self: shown.append(self)
    QApplication.exec = lambda self: 0
    code = define.main(sys.argv[1:])
    view = shown[0].view3d.cloud_view
    print(json.dumps({"code": code, "gl": isinstance(view, GLCloudView), "reason": view.render_path.reason}))
    shown[0].close()
""")


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="needs xvfb-run (Xvfb) and Mesa")
@pytest.mark.parametrize(("environment", "option", "gl"), [("software", "opengl", True), ("opengl", "software", False)])
def test_under_xvfb_the_option_decides_the_view(tmp_path, environment, option, gl):
    script = tmp_path / "window.py"
    script.write_text(WINDOW_SCRIPT)
    env = {**os.environ, "QT_QPA_PLATFORM": "xcb", "OBJREC_RENDERER": environment,
           "XDG_CONFIG_HOME": str(tmp_path)}  # the window's settings go here, not to the user's
    env.pop("OBJREC_GL", None)
    done = subprocess.run(["xvfb-run", "-a", sys.executable, str(script), "shape", "--paused", "--renderer", option],
                          capture_output=True, text=True, timeout=180, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    shown = json.loads(done.stdout.strip().splitlines()[-1])
    assert shown == {"code": 0, "gl": gl, "reason": f"asked for (--renderer {option})"}
