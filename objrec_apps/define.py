"""objrec-define: the definition GUI. Tune a pipeline live and save the parameter file objrec-detect runs.

    objrec-define hsv|feature|shape [--source SPEC]   a shipped system (objrec_apps/systems/*_demo.yaml), untitled
    objrec-define PARAMS_FILE [--source SPEC]         any parameter file, its pipeline built from the file
    objrec-define                                     an empty window (build a pipeline from the Pipeline menu)

Exit codes: 0 closed normally; 2 a user mistake (bad parameter file, source or option, no display, no Qt).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from importlib import resources
from pathlib import Path
from typing import Any

import objrec_core
from objrec_core import (
    FrameSource,
    ParameterFileError,
    RecognitionSystem,
    SourceError,
    UnknownModuleError,
    build_system,
    source_kinds,
)
from strictio import InputError, OutputError
from strictio.cli_numbers import CommandLineParser, check_limit_settings
from strictio.signals import handling

from .cli import USER_ERROR, UserError, configure_logging, report
from .launch import ending_at_once

PROG = "objrec-define"
#: The shipped starting systems (package data in objrec_apps/systems/), by the name given on the command line.
SYSTEMS = {"hsv": "hsv_demo.yaml", "feature": "feature_demo.yaml", "shape": "shape_demo.yaml"}


def starting_system(name: str) -> RecognitionSystem:
    """A new system built from the shipped file of ``name`` (``hsv``, ``feature``, ``shape``), read as
    package data so it works from a wheel as from the repository. KeyError for an unknown name."""
    resource = resources.files("objrec_apps") / "systems" / SYSTEMS[name]
    with resources.as_file(resource) as path:
        return build_system(path)


def build_parser() -> argparse.ArgumentParser:
    parser = CommandLineParser(
        prog=PROG,
        description="Tune a recognition pipeline on live data and save the parameter file objrec-detect runs.",
    )
    parser.add_argument(
        "system", nargs="?", metavar="hsv|feature|shape|PARAMS_FILE",
        help="one of the three built-in systems, or a parameter file to open (none: an empty window)",
    )
    parser.add_argument("--source", "-s", default=None,
                        help="a source spec: demo, demo:seed=N,frames=N, camera:N, or a path (default: the "
                        "pipeline's own demo source)")
    parser.add_argument("--view", choices=("tabs", "grid"), help="show the stages as tabs or as a grid")
    parser.add_argument("--paused", action="store_true", help="start paused on the first frame")
    # the choices are render_path.RENDERER_OPTIONS, written out: --help and a bad option work without Qt
    parser.add_argument("--renderer", choices=("auto", "opengl", "software"), default=None,
                        help="how the 3D view draws: auto (the default) takes OpenGL on a graphics card and the "
                        "NumPy renderer where OpenGL is drawn by the processor; opengl or software forces one. "
                        "Wins over OBJREC_RENDERER")
    parser.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    return parser


def load_system(choice: str | None) -> tuple[RecognitionSystem, Path | None, str | None]:
    """The system to open, the parameter file's path (None: untitled) and, for a shipped system, the name of
    the file it was started from (Save then asks where rather than overwriting the shipped file)."""
    if choice is None:
        return RecognitionSystem(), None, None
    if choice in SYSTEMS and not Path(choice).is_file():
        try:
            return starting_system(choice), None, SYSTEMS[choice]
        except (ParameterFileError, UnknownModuleError) as exc:
            raise UserError(f"the {choice} system cannot be built: {exc}") from None
    path = Path(choice)
    if not path.exists() and path.suffix.lower() not in (".yaml", ".yml"):
        raise UserError(f"{choice}: neither one of {', '.join(SYSTEMS)} nor an existing parameter file")
    try:
        return build_system(path), path, None
    except ParameterFileError as exc:
        raise UserError(str(exc)) from None


def open_source(spec: str, kind: str | None) -> FrameSource | str:
    """Open the source now, so a bad one is a clear error before any window appears. With no pipeline kind
    yet, a spec of several kinds (``demo``) is handed to the window as it is: it opens once the pipeline has
    a kind."""
    try:
        if kind is None and len(source_kinds(spec)) > 1:
            return spec
        return objrec_core.open_source(spec, kind)
    except (SourceError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None


#: The libraries Qt's X11 platform plug-in loads beyond plain libxcb, with their Debian/Ubuntu packages.
XCB_LIBRARIES = {
    "xcb-cursor": "libxcb-cursor0",
    "xcb-icccm": "libxcb-icccm4",
    "xcb-image": "libxcb-image0",
    "xcb-keysyms": "libxcb-keysyms1",
    "xcb-randr": "libxcb-randr0",
    "xcb-render-util": "libxcb-render-util0",
    "xcb-shape": "libxcb-shape0",
    "xcb-xkb": "libxcb-xkb1",
    "xkbcommon-x11": "libxkbcommon-x11-0",
}


def missing_xcb_packages() -> list[str]:
    """The packages of the X11 plug-in's libraries that cannot be found (Qt would abort without them)."""
    from ctypes.util import find_library

    return [package for library, package in XCB_LIBRARIES.items() if find_library(library) is None]


def check_display() -> None:
    """Qt aborts the process without a display or without its X11 libraries; say so in one line instead."""
    platform = os.environ.get("QT_QPA_PLATFORM", "")
    if not sys.platform.startswith("linux") or (platform and not platform.startswith("xcb")):
        return
    if not platform and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise UserError(
            "no display: DISPLAY and WAYLAND_DISPLAY are not set. Run it on a desktop, over ssh -X, under "
            "xvfb-run, or with QT_QPA_PLATFORM=offscreen (nothing is shown then)"
        )
    if os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        missing = missing_xcb_packages()
        if missing:
            raise UserError(
                f"Qt's X11 platform needs libraries that are not installed; on Debian/Ubuntu: "
                f"sudo apt-get install {' '.join(missing)}"
            )


def import_qt() -> Any:
    try:
        from PySide6.QtWidgets import QApplication

        import objrec_apps.gui  # noqa: F401 - first, for its guard against a PySide6 bug (gui/compat.py)
    except ImportError as exc:
        raise UserError(f"the GUI needs PySide6, which cannot be imported ({exc}); install objrec[gui]") from None
    return QApplication


def run(args: argparse.Namespace) -> int:
    check_display()
    application_class = import_qt()
    system, path, origin = load_system(args.system)
    spec = args.source
    if spec is None:  # each kind names its own demo; an empty window waits for one
        spec = objrec_core.get_kind(system.kind).demo_spec if system.kind else "demo"
    source = open_source(spec, system.kind)
    from objrec_apps.gui import render_path

    render_path.ask(args.renderer)
    application = application_class.instance() or application_class([PROG])
    application.setApplicationName(PROG)
    application.setOrganizationName("objrec")
    from objrec_apps.gui import DefinitionGUI

    window = DefinitionGUI(system, source=source, view_mode=args.view, paused=args.paused, first_frame=True)
    if path is not None:
        window.files.remember_folder(path)
        window.files.set_path(path)
        window.show_message(f"Opened {path}")
    elif origin is not None:
        window.files.set_origin(origin)
        window.show_message(f"Started from the shipped {origin}: Save asks where to save your version")
    window.show()
    # Ctrl-C in the terminal closes the window as File>Quit would (settings saved, thread stopped). Qt's loop
    # runs no Python between events, so a timer lets the interpreter look at its signals now and then.
    from PySide6.QtCore import QTimer

    ticker = QTimer()
    ticker.timeout.connect(lambda: None)
    ticker.start(250)
    try:
        with handling(lambda _signum, _frame: window.close(), (signal.SIGINT,)):
            return int(application.exec())
    finally:
        ticker.stop()


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        configure_logging(PROG, args.verbose)
        check_limit_settings()
        # Until the window takes Ctrl-C over (closing as File>Quit would), there is nothing to save, and an
        # interrupt inside Qt's start-up would leave its threads hanging: end at once instead.
        with ending_at_once(PROG, (signal.SIGINT,)):
            return run(args)
    except (UserError, InputError, OutputError) as exc:
        report(PROG, exc)
        return USER_ERROR
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
