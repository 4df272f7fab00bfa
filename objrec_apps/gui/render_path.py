"""Which 3D view draws the cloud on this machine: OpenGL on a graphics card, the NumPy renderer otherwise.

OpenGL is only fast on a GPU. Mesa's software rasterisers (llvmpipe, softpipe) turned the 307,200-point mug
scan at 8-14 frames/s on a 2-core laptop without a GPU, where the NumPy renderer (``cloud_render``) gives
40-70: so a software OpenGL is not chosen. The choice reads the OpenGL renderer's own name (``GL_RENDERER``)
from a context made once at start-up, and can be overridden, on the command line (``objrec-define --renderer``,
which wins) or in the environment:

- ``auto`` (the default): as above;
- ``opengl`` (or ``gl``): OpenGL wherever a context can be made, even a software one;
- ``software``: the NumPy renderer always (so does the older ``OBJREC_GL=0``).
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass

from PySide6.QtGui import QGuiApplication, QOffscreenSurface, QOpenGLContext

log = logging.getLogger(__name__)

#: The environment variable that overrides the choice.
RENDERER_ENV = "OBJREC_RENDERER"
#: Its values, and what each means.
CHOICES = {"auto": "auto", "opengl": "opengl", "gl": "opengl", "software": "software", "numpy": "software"}
#: The values the command line offers (``objrec-define --renderer``).
RENDERER_OPTIONS = ("auto", "opengl", "software")
#: Platforms where Qt cannot make an OpenGL context for a widget.
NO_GL_PLATFORMS = frozenset({"offscreen", "minimal", "vnc", "linuxfb"})
#: Parts of GL_RENDERER strings of OpenGL drawn by the processor, not a graphics card (Mesa's llvmpipe,
#: softpipe and swrast, Google's SwiftShader, Windows' fallback drivers).
SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "software", "swiftshader", "lavapipe",
               "microsoft basic render", "gdi generic")
GL_VENDOR = 0x1F00
GL_RENDERER = 0x1F01


@dataclass(frozen=True)
class RenderPath:
    """The renderer chosen (``opengl`` True: the OpenGL view), why, and the OpenGL renderer's name where it
    was read ("" otherwise)."""

    opengl: bool
    reason: str
    renderer: str = ""

    @property
    def name(self) -> str:
        return "OpenGL" if self.opengl else "software renderer"


#: The choice given on the command line, for this process (a one-item list once given).
_command_line: list[str] = []


def ask(choice: str | None) -> None:
    """Take the command line's choice (``auto``, ``opengl``, ``software``; None: none given, the environment
    decides). It wins over ``OBJREC_RENDERER`` and ``OBJREC_GL``: a user typing an option means it now, a
    variable may be left over from a shell profile. ValueError for any other value."""
    _command_line.clear()
    if choice is None:
        return
    if choice not in RENDERER_OPTIONS:
        raise ValueError(f"--renderer: {choice!r} is not one of {', '.join(RENDERER_OPTIONS)}")
    _command_line.append(choice)


def requested_by() -> tuple[str, str]:
    """The choice asked for, ``auto``, ``opengl`` or ``software``, and by what (``--renderer opengl``,
    ``OBJREC_RENDERER=software``, ``OBJREC_GL=0``; "" for the default): the command line first, then the
    environment. An unknown value in the environment is logged as one line and read as ``auto``."""
    if _command_line:
        return _command_line[0], f"--renderer {_command_line[0]}"
    if os.environ.get("OBJREC_GL", "1") == "0":
        return "software", "OBJREC_GL=0"
    value = os.environ.get(RENDERER_ENV, "auto").strip().lower() or "auto"
    if value not in CHOICES:
        log.warning("%s=%s is not one of auto, opengl, software: choosing automatically", RENDERER_ENV, value)
        return "auto", ""
    return CHOICES[value], f"{RENDERER_ENV}={value}" if value != "auto" else ""


def requested() -> str:
    """The choice asked for (``requested_by``), without saying by what."""
    return requested_by()[0]


def is_software_gl(renderer: str) -> bool:
    """Whether an OpenGL renderer string names a software rasteriser (no graphics card)."""
    lowered = renderer.lower()
    return any(name in lowered for name in SOFTWARE_GL)


def gl_renderer() -> str | None:
    """The GL_RENDERER string of an OpenGL context made here (with its vendor), None where no context can
    be made (a platform without OpenGL, a driver that refuses)."""
    if QGuiApplication.platformName() in NO_GL_PLATFORMS:
        return None
    context = QOpenGLContext()
    if not context.create():
        return None
    surface = QOffscreenSurface()
    surface.setFormat(context.format())
    surface.create()
    try:
        if not context.makeCurrent(surface):
            return ""  # a context without a current surface: OpenGL exists, its name is unknown
        functions = context.functions()
        renderer = str(functions.glGetString(GL_RENDERER) or "")
        vendor = str(functions.glGetString(GL_VENDOR) or "")
        context.doneCurrent()
    finally:
        surface.destroy()
    return f"{renderer} ({vendor})" if vendor else renderer


#: The GL_RENDERER string read in this process (a one-item list once read): a context is made only once.
_read: list[str | None] = []


def read_gl_renderer() -> str | None:
    """``gl_renderer()``, read once per process."""
    if not _read:
        _read.append(gl_renderer())
    return _read[0]


def choose_render_path(choice: str | None = None, renderer: str | None = "read") -> RenderPath:
    """The renderer for this machine. ``choice`` (``auto``, ``opengl``, ``software``) overrides the command
    line's and the environment's (``requested_by``); ``renderer`` is the GL_RENDERER string to judge ("read":
    ask OpenGL, once per process; None: no OpenGL here)."""
    asker = "by the caller"
    if choice is None:
        choice, asker = requested_by()
    else:
        choice = CHOICES.get(choice, "auto")
    if choice == "software":
        return RenderPath(False, f"asked for ({asker})")
    if renderer == "read":
        renderer = read_gl_renderer()
    if renderer is None:
        return RenderPath(False, f"no OpenGL on the {QGuiApplication.platformName()} platform")
    if choice == "opengl":
        return RenderPath(True, f"asked for ({asker})", renderer)
    if is_software_gl(renderer):
        return RenderPath(False, f"OpenGL is drawn by the processor ({renderer}): the NumPy renderer is faster",
                          renderer)
    return RenderPath(True, f"a graphics card draws OpenGL ({renderer or 'unnamed'})", renderer)
